#!/usr/bin/env python3
"""A Planet client written from docs/planet.md and the generated schema alone (no URSLink code).

It proves the protocol is language-neutral: handshake with a named credential (its token), calls
to the diagnostic agent without a deadline of their own (the service's applies), a subscription,
and an event delivered to it.
"""
import argparse
import socket
import struct
import sys


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server", required=True, help="HOST:PORT")
    parser.add_argument("--token-file", required=True, help="the token of this client's credential")
    parser.add_argument("--pythonpath", required=True, help="colon-separated folders of generated modules")
    parser.add_argument("--sleep-ms", type=int, default=0, help="diag.sleep called without a deadline")
    parser.add_argument("--tls-ca", help="speak TLS 1.3, verifying the server against these CAs (PEM)")
    args = parser.parse_args()
    sys.path[:0] = args.pythonpath.split(":")
    import planet_pb2
    import Diagnostic_pb2

    host, port = args.server.rsplit(":", 1)
    sock = socket.create_connection((host, int(port)), timeout=10)
    if args.tls_ca:
        import ssl
        context = ssl.create_default_context(cafile=args.tls_ca)
        context.minimum_version = ssl.TLSVersion.TLSv1_3
        sock = context.wrap_socket(sock, server_hostname=host)
    buffered = bytearray()
    partial = {}  # Chunk.message_id -> bytearray

    def send(frame):
        data = frame.SerializeToString()
        sock.sendall(struct.pack(">I", len(data)) + data)

    def read_exact(n):
        while len(buffered) < n:
            piece = sock.recv(65536)
            if not piece:
                raise RuntimeError("server closed the connection")
            buffered.extend(piece)
        out = bytes(buffered[:n])
        del buffered[:n]
        return out

    def call(call_id, operation, request, oneway=False):
        """Sends a Request to the diag service: `operation` with `request`, a Diagnostic_pb2 message."""
        frame = planet_pb2.Frame()
        frame.request.call_id = call_id
        frame.request.service = "diag"
        frame.request.operation = operation
        frame.request.oneway = oneway
        frame.request.payload = request.SerializeToString()
        send(frame)

    def receive():
        """Next complete frame, answering pings and reassembling chunks on the way."""
        while True:
            (length,) = struct.unpack(">I", read_exact(4))
            frame = planet_pb2.Frame()
            frame.ParseFromString(read_exact(length))
            kind = frame.WhichOneof("body")
            if kind == "ping":
                pong = planet_pb2.Frame()
                pong.pong.nonce = frame.ping.nonce
                send(pong)
                continue
            if kind == "chunk":
                data = partial.setdefault(frame.chunk.message_id, bytearray())
                data.extend(frame.chunk.data)
                if not frame.chunk.last:
                    continue
                whole = planet_pb2.Frame()
                whole.ParseFromString(bytes(partial.pop(frame.chunk.message_id)))
                frame, kind = whole, whole.WhichOneof("body")
            return kind, frame

    hello = planet_pb2.Frame()
    hello.hello.version = 1
    hello.hello.token = open(args.token_file).read().strip()
    hello.hello.peer_name = "python-client"
    hello.hello.role = planet_pb2.CLIENT
    send(hello)
    kind, frame = receive()
    if kind != "welcome":
        print("handshake failed:", frame)
        return 1
    # welcome.session_secret would resume this session after a reconnect: kept, never printed.
    print("welcome: space", frame.welcome.space, "as", frame.welcome.identity,
          "role", planet_pb2.Role.Name(frame.welcome.role))

    # No deadline_ms (0): the server applies the deadline diag advertised when it registered.
    call(1, "echo", Diagnostic_pb2.Diagnostic_echo_Request(text="hola"))
    kind, frame = receive()
    if kind != "reply" or frame.reply.status != planet_pb2.OK:
        print("call failed:", frame)
        return 1
    reply = Diagnostic_pb2.Diagnostic_echo_Reply()
    reply.ParseFromString(frame.reply.payload)
    print("echo reply:", reply.result)

    # A call longer than that deadline: the server cuts it there and says which deadline it was.
    call(2, "sleep", Diagnostic_pb2.Diagnostic_sleep_Request(ms=args.sleep_ms))
    kind, frame = receive()
    if kind != "reply":
        print("sleep: no reply:", frame)
        return 1
    print("sleep reply:", planet_pb2.Status.Name(frame.reply.status), frame.reply.message)

    subscribe = planet_pb2.Frame()
    subscribe.subscribe.subscription_id = 1
    subscribe.subscribe.pattern = "lab/python"
    send(subscribe)
    kind, frame = receive()
    if kind != "subscribe_ack" or frame.subscribe_ack.status != planet_pb2.OK:
        print("subscribe failed:", frame)
        return 1

    call(3, "notify", Diagnostic_pb2.Diagnostic_notify_Request(topic="lab/python", text="from python"), oneway=True)
    while True:
        kind, frame = receive()
        if kind == "event":
            event = Diagnostic_pb2.Diagnostic_notify_Request()
            event.ParseFromString(frame.event.payload)
            print("event:", frame.event.topic, event.text, "seq", frame.event.seq)
            return 0


if __name__ == "__main__":
    sys.exit(main())
