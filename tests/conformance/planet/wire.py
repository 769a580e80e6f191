"""One Planet connection driven by hand: framing, chunking both ways, heartbeats, bounded waits."""
import socket
import struct
import time

import planet_pb2 as pl

MIN_CHUNK_BYTES = 512


class Closed(Exception):
    """The server closed the connection."""


class Connection:
    """A TCP connection speaking Planet frames. Every wait is bounded by a timeout."""

    def __init__(self, host, port, timeout=10.0, tls=None):
        """`tls`: an ssl.SSLContext for Planet over TLS (docs/planet.md section 1), or None for TCP."""
        self.sock = socket.create_connection((host, port), timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if tls is not None:
            self.sock = tls.wrap_socket(self.sock, server_hostname=host)
        self.buffer = bytearray()
        self.partial = {}          # Chunk.message_id -> bytearray
        self.next_message_id = 1
        self.chunk_bytes = 64 * 1024   # until a Welcome says otherwise
        self.max_frame = 64 * 1024
        self.eof = False
        self.welcome = None
        self.answer_pings = True
        self.pings = 0

    def close(self):
        try:
            self.sock.close()
        except OSError:
            pass

    # ---- sending -------------------------------------------------------------------------------

    def send_raw(self, data):
        try:
            self.sock.sendall(data)
        except OSError:
            self.eof = True

    def send_all(self, frames):
        """Sends small frames back to back in one write, as a peer in a hurry would."""
        data = bytearray()
        for frame in frames:
            body = frame.SerializeToString()
            data += struct.pack(">I", len(body)) + body
        self.send_raw(bytes(data))

    def send(self, frame):
        """Sends `frame`, as Chunk frames when its serialized size exceeds chunk_bytes."""
        data = frame.SerializeToString()
        if len(data) <= self.chunk_bytes:
            self.send_raw(struct.pack(">I", len(data)) + data)
            return
        message_id = self.next_message_id
        self.next_message_id += 1
        piece = self.chunk_bytes - 64
        for offset in range(0, len(data), piece):
            chunk = pl.Frame()
            chunk.chunk.message_id = message_id
            chunk.chunk.total_bytes = len(data)
            chunk.chunk.offset = offset
            chunk.chunk.data = data[offset:offset + piece]
            chunk.chunk.last = offset + piece >= len(data)
            body = chunk.SerializeToString()
            self.send_raw(struct.pack(">I", len(body)) + body)

    def ping(self, nonce):
        """Sends Ping{nonce}."""
        frame = pl.Frame()
        frame.ping.nonce = nonce
        self.send(frame)

    # ---- receiving -----------------------------------------------------------------------------

    def _fill(self, n, deadline):
        while len(self.buffer) < n:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError
            self.sock.settimeout(left)
            try:
                piece = self.sock.recv(1 << 16)
            except socket.timeout:
                raise TimeoutError
            except OSError:
                piece = b""
            if not piece:
                self.eof = True
                raise Closed
            self.buffer.extend(piece)

    def _frame(self, deadline):
        self._fill(4, deadline)
        (length,) = struct.unpack(">I", bytes(self.buffer[:4]))
        if length == 0 or length > self.max_frame:
            raise ValueError("the server sent a frame of %d bytes (limit %d)" % (length, self.max_frame))
        self._fill(4 + length, deadline)
        body = bytes(self.buffer[4:4 + length])
        del self.buffer[:4 + length]
        frame = pl.Frame()
        frame.ParseFromString(body)
        return frame

    def recv(self, timeout=10.0):
        """The next whole message (chunks reassembled), answering Pings on the way.

        Returns None on timeout; raises Closed when the server closed the connection."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                frame = self._frame(deadline)
            except TimeoutError:
                return None
            kind = frame.WhichOneof("body")
            if kind == "ping":
                self.pings += 1
                if self.answer_pings:
                    pong = pl.Frame()
                    pong.pong.nonce = frame.ping.nonce
                    self.send(pong)
                    continue
                return frame
            if kind == "chunk":
                c = frame.chunk
                data = self.partial.setdefault(c.message_id, bytearray())
                if c.offset != len(data):
                    raise ValueError("chunk of message %d at offset %d, expected %d" % (c.message_id, c.offset, len(data)))
                data.extend(c.data)
                if not c.last:
                    continue
                whole = pl.Frame()
                whole.ParseFromString(bytes(self.partial.pop(c.message_id)))
                return whole
            return frame

    def expect(self, kind, timeout=10.0, match=None):
        """The next message of `kind` (and satisfying `match`), skipping others; None on timeout."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            frame = self.recv(left)
            if frame is None:
                return None
            if frame.WhichOneof("body") == kind and (match is None or match(getattr(frame, kind))):
                return frame

    def closed_by_server(self, timeout=10.0):
        """True once the server closed the connection within `timeout` (frames are drained)."""
        deadline = time.monotonic() + timeout
        try:
            while time.monotonic() < deadline:
                self.recv(deadline - time.monotonic())
        except (Closed, ValueError):
            return True
        return self.eof

    # ---- handshake -----------------------------------------------------------------------------

    def hello(self, token="", peer_name="conformance", role=pl.CLIENT, secret="", version=1, timeout=10.0):
        """Sends Hello; returns the first frame the server answers (Welcome, Refused, Goodbye)."""
        frame = pl.Frame()
        frame.hello.version = version
        frame.hello.token = token
        frame.hello.peer_name = peer_name
        frame.hello.role = role
        frame.hello.session_secret = secret
        self.send(frame)
        answer = self.recv(timeout)
        if answer is not None and answer.WhichOneof("body") == "welcome":
            self.welcome = answer.welcome
            if answer.welcome.chunk_bytes >= MIN_CHUNK_BYTES:
                self.chunk_bytes = min(self.chunk_bytes, answer.welcome.chunk_bytes)
                self.max_frame = max(self.max_frame, answer.welcome.chunk_bytes)
        return answer
