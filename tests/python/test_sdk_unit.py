#!/usr/bin/python3
"""Unit tests of the Python SDK (python/urslink) without a server: framing and chunk reassembly
with their limits, interfaces built from IDL at run time, the types of an IDL file without an
interface, an agent's dispatch (results, declared exceptions, errors), and a Client speaking to a
scripted server on loopback (handshake, Pings, Refused, heartbeat timeout, an oversized frame, a
call lost with its connection, an event of such a type published and received).

  python3 -m unittest tests/python/test_sdk_unit.py   (from the repository root)"""
import asyncio
import logging
import os
import struct
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "python"))
os.environ.setdefault("URS_OMNIIDL_BACKEND_DIR", os.path.join(ROOT, "idl", "omniidl_planet"))

import urslink  # noqa: E402
from urslink import planet_pb2 as pl  # noqa: E402
from urslink.wire import ProtocolError, Reassembler, encode, read_frame  # noqa: E402

THERMOSTAT = os.path.join(ROOT, "examples", "python", "Thermostat.idl")
BASIC_DATA_TYPES = os.path.join(ROOT, "idl", "rtc", "BasicDataType.idl")   # OpenRTM-aist's: structs, no interface
logging.getLogger("urslink").setLevel(logging.CRITICAL)   # the tests read last_error, not the log


def split(data):
    """Frames of a byte string written by encode()."""
    out = []
    while data:
        (n,) = struct.unpack(">I", data[:4])
        frame = pl.Frame()
        frame.ParseFromString(data[4:4 + n])
        out.append(frame)
        data = data[4 + n:]
    return out


class WireTest(unittest.TestCase):
    def test_small_frame_is_not_chunked(self):
        frame = pl.Frame(ping=pl.Ping(nonce=7))
        self.assertEqual(split(encode(frame, 512, lambda: 1)), [frame])

    def test_large_frame_is_chunked_and_reassembled(self):
        frame = pl.Frame(request=pl.Request(call_id=3, service="s", operation="o", payload=os.urandom(5000)))
        pieces = split(encode(frame, 512, lambda: 9))
        self.assertGreater(len(pieces), 9)
        for piece in pieces:
            self.assertLessEqual(piece.ByteSize(), 512)
        reassembler = Reassembler(1 << 20)
        results = [reassembler.feed(p) for p in pieces]
        self.assertTrue(all(r is None for r in results[:-1]))
        self.assertEqual(results[-1], frame)

    def test_reassembly_limits(self):
        def chunk(**fields):
            return pl.Frame(chunk=pl.Chunk(**fields))
        with self.assertRaisesRegex(ProtocolError, "never started"):
            Reassembler(100).feed(chunk(message_id=1, total_bytes=10, offset=5, data=b"x"))
        with self.assertRaises(ProtocolError) as raised:
            Reassembler(100).feed(chunk(message_id=1, total_bytes=101, offset=0, data=b"x"))
        self.assertEqual(raised.exception.status, pl.PAYLOAD_TOO_LARGE)
        reassembler = Reassembler(100)
        reassembler.feed(chunk(message_id=1, total_bytes=10, offset=0, data=b"x"))
        with self.assertRaisesRegex(ProtocolError, "does not continue"):
            reassembler.feed(chunk(message_id=1, total_bytes=10, offset=3, data=b"y"))
        with self.assertRaisesRegex(ProtocolError, "'last'"):
            Reassembler(100).feed(chunk(message_id=2, total_bytes=1, offset=0, data=b"x", last=False))
        many = Reassembler(100)
        for i in range(16):
            many.feed(chunk(message_id=i, total_bytes=10, offset=0, data=b"x"))
        with self.assertRaisesRegex(ProtocolError, "in progress"):
            many.feed(chunk(message_id=99, total_bytes=10, offset=0, data=b"x"))

    def test_frame_length_checked_before_reading(self):
        async def run(data, limit):
            reader = asyncio.StreamReader()
            reader.feed_data(data)
            reader.feed_eof()
            return await read_frame(reader, limit)
        with self.assertRaises(ProtocolError) as raised:
            asyncio.run(run(struct.pack(">I", 1 << 31), 65536))
        self.assertEqual(raised.exception.status, pl.PAYLOAD_TOO_LARGE)
        self.assertIn("2147483648 bytes exceeds the limit of 65536", str(raised.exception))
        with self.assertRaisesRegex(ProtocolError, "0 bytes"):
            asyncio.run(run(struct.pack(">I", 0), 65536))
        with self.assertRaisesRegex(ProtocolError, "does not parse"):
            asyncio.run(run(struct.pack(">I", 2) + b"\xff\xff", 65536))


class InterfaceTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.interface = urslink.Interface.from_idl(THERMOSTAT)

    def test_methods_from_idl(self):
        methods = self.interface.methods
        self.assertEqual(self.interface.name, "Demo.Thermostat")
        self.assertEqual(sorted(methods), ["_get_room", "nudge", "read", "setTarget"])
        self.assertTrue(methods["nudge"].oneway)
        self.assertFalse(methods["read"].oneway)
        self.assertEqual(methods["setTarget"].raises, ["Demo.OutOfRange"])
        self.assertEqual(methods["setTarget"].request(celsius=3).celsius, 3)

    def test_exception_round_trip(self):
        raised = self.interface.exception("OutOfRange", requested=40, min=5, max=30)
        self.assertEqual(raised.type_name, "Demo.OutOfRange")
        decoded = self.interface.decode_exception(raised.type_name, raised.payload, "")
        self.assertEqual(decoded.fields, {"requested": 40.0, "min": 5.0, "max": 30.0})
        self.assertEqual(decoded.code, "USER_EXCEPTION")
        unknown = self.interface.decode_exception("Other.Thing", b"\x01", "why")
        self.assertIsNone(unknown.value)
        self.assertEqual(unknown.fields, {})

    def test_idl_errors_name_the_file(self):
        with self.assertRaisesRegex(urslink.IdlError, "does not exist"):
            urslink.Interface.from_idl("/nonexistent/X.idl")
        bad = os.path.join(ROOT, "tests", "unit", "schema", "idl", "refused", "Any.idl")
        if os.path.exists(bad):
            with self.assertRaisesRegex(urslink.IdlError, "Any.idl:.*any"):
                urslink.Interface.from_idl(bad)

    def test_descriptor_set_needs_a_known_service(self):
        with self.assertRaisesRegex(ValueError, "no service 'Demo.Nope'"):
            urslink.Interface(self.interface.descriptor_set, "Demo.Nope")


class TypesTest(unittest.TestCase):
    """urslink.Types: the message types of an IDL file that declares no interface."""

    @classmethod
    def setUpClass(cls):
        cls.types = urslink.Types.from_idl(BASIC_DATA_TYPES)

    def test_types_of_a_file_without_interface(self):
        self.assertIn("RTC.TimedLong", self.types.messages)
        self.assertIn("RTC.TimedDoubleSeq", self.types.messages)
        self.assertNotIn("google.protobuf.FileDescriptorProto", self.types.messages)
        TimedLong = self.types.message_class("RTC.TimedLong")
        value = TimedLong(tm=self.types.message_class("RTC.Time")(sec=12, nsec=345), data=-7)
        self.assertEqual(TimedLong.FromString(value.SerializeToString()), value)
        self.assertEqual(value.DESCRIPTOR.full_name, "RTC.TimedLong")
        with self.assertRaisesRegex(ValueError, r"^the descriptor set declares no service \(its IDL file has no "
                                                r"interface\): load its message types with urslink.Types$"):
            urslink.Interface.from_idl(BASIC_DATA_TYPES)

    def test_an_interface_is_types_too(self):
        interface = urslink.Interface.from_idl(THERMOSTAT)
        self.assertIn("Demo.Reading", interface.messages)
        self.assertEqual(urslink.Types(interface.descriptor_set).messages, interface.messages)

    def test_decode_names_what_it_cannot_decode(self):
        with self.assertRaisesRegex(ValueError, r"^the event on 'rt/count' has content type 'RTC.Nothing', which is "
                                                r"none of these types: load the IDL file that declares it$"):
            self.types.decode(pl.Event(topic="rt/count", content_type="RTC.Nothing"))
        with self.assertRaisesRegex(ValueError, r"^the payload of the event on 'rt/count' \(2 bytes\) is no "
                                                r"RTC.TimedLong: "):
            self.types.decode(pl.Event(topic="rt/count", content_type="RTC.TimedLong", payload=b"\xff\xff"))


class AgentTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.interface = urslink.Interface.from_idl(THERMOSTAT)

    def dispatch(self, agent, operation, payload=b"", oneway=False):
        request = pl.Request(call_id=1, service="thermo", operation=operation, payload=payload, oneway=oneway,
                             deadline_ms=500, caller=pl.Caller(name="operator-ann", role=pl.CLIENT))
        return asyncio.run(agent._dispatch(request))

    def test_results_and_errors(self):
        interface = self.interface
        seen = {}

        class Thermo(urslink.Agent):
            def _get_room(self, request):
                seen["call"] = urslink.current_call()
                return "lab"

            async def read(self, request):
                return {"result": {"celsius": 20, "target": 21}}

            def setTarget(self, request):
                if request.celsius > 30:
                    raise interface.exception("OutOfRange", requested=request.celsius, min=5, max=30)
                if request.celsius < 0:
                    raise urslink.PlanetError(pl.BAD_ARGUMENTS, "below zero")
                if request.celsius == 13:
                    raise RuntimeError("unlucky")
                return 42   # not a Reading

        agent = Thermo(interface)
        status, _, payload, _ = self.dispatch(agent, "_get_room")
        self.assertEqual(status, pl.OK)
        self.assertEqual(interface.methods["_get_room"].reply.FromString(payload).result, "lab")
        self.assertEqual((seen["call"].operation, seen["call"].deadline_ms), ("_get_room", 500))
        self.assertEqual((seen["call"].caller, seen["call"].caller_role), ("operator-ann", "client"))
        status, _, payload, _ = self.dispatch(agent, "read")
        self.assertEqual(interface.methods["read"].reply.FromString(payload).result.target, 21)
        request = interface.methods["setTarget"].request
        status, message, payload, type_name = self.dispatch(agent, "setTarget", request(celsius=31).SerializeToString())
        self.assertEqual((status, type_name), (pl.USER_EXCEPTION, "Demo.OutOfRange"))
        self.assertEqual(interface.message_class(type_name).FromString(payload).requested, 31)
        status, message, _, _ = self.dispatch(agent, "setTarget", request(celsius=-1).SerializeToString())
        self.assertEqual((status, message), (pl.BAD_ARGUMENTS, "below zero"))
        status, message, _, _ = self.dispatch(agent, "setTarget", request(celsius=13).SerializeToString())
        self.assertEqual(status, pl.INTERNAL)
        self.assertIn("RuntimeError: unlucky", message)
        status, message, _, _ = self.dispatch(agent, "setTarget", request(celsius=20).SerializeToString())
        self.assertEqual(status, pl.INTERNAL)
        self.assertIn("cannot make a Demo.Thermostat_setTarget_Reply", message)
        status, message, _, _ = self.dispatch(agent, "nudge")
        self.assertEqual(status, pl.UNKNOWN_OPERATION)
        self.assertIn("does not implement nudge", message)
        status, _, _, _ = self.dispatch(agent, "explode")
        self.assertEqual(status, pl.UNKNOWN_OPERATION)
        status, message, _, _ = self.dispatch(agent, "setTarget", b"\xff\xff")
        self.assertEqual(status, pl.BAD_ARGUMENTS)


    def test_blocking_handlers_run_in_threads(self):
        import threading

        class Slow(urslink.Agent):
            blocking = True

            def _get_room(self, request):
                return "%s %s" % (threading.current_thread() is threading.main_thread(),
                                  urslink.current_call().operation)

        status, _, payload, _ = self.dispatch(Slow(self.interface), "_get_room")
        self.assertEqual(status, pl.OK)
        self.assertEqual(self.interface.methods["_get_room"].reply.FromString(payload).result, "False _get_room")


class ScriptedServer:
    """A loopback server answering the first Hello with `answer(hello)` and then running `script`."""

    def __init__(self, answer, script=None):
        self.answer = answer
        self.script = script
        self.hellos = []

    async def __aenter__(self):
        self.server = await asyncio.start_server(self.handle, "127.0.0.1", 0)
        self.address = "127.0.0.1:%d" % self.server.sockets[0].getsockname()[1]
        return self

    async def __aexit__(self, *exc):
        self.server.close()
        await self.server.wait_closed()

    def send(self, writer, frame):
        data = frame.SerializeToString()
        writer.write(struct.pack(">I", len(data)) + data)

    async def handle(self, reader, writer):
        try:
            hello = await read_frame(reader, 65536)
            self.hellos.append(hello.hello)
            self.send(writer, self.answer(hello.hello))
            if self.script:
                await self.script(self, reader, writer)
            else:
                await reader.read()
        except (asyncio.IncompleteReadError, ConnectionError):
            pass
        finally:
            writer.close()


def welcome(hello, timeout_ms=3000):
    return pl.Frame(welcome=pl.Welcome(version=1, space="unit", server_instance="0", heartbeat_interval_ms=1000,
                                       heartbeat_timeout_ms=timeout_ms, max_message_bytes=1 << 20, chunk_bytes=4096,
                                       session_secret="s" * 64, identity="unit-client", role=pl.CLIENT))


class ClientTest(unittest.TestCase):
    def test_handshake_and_ping(self):
        async def script(server, reader, writer):
            server.send(writer, pl.Frame(ping=pl.Ping(nonce=99)))
            pong = await read_frame(reader, 65536)
            server.pong = pong.pong.nonce
            await reader.read()

        async def run():
            async with ScriptedServer(welcome, script) as server:
                client = urslink.Client(server.address, token="t0ken", peer_name="unit", role="sam")
                await client.start(timeout=5)
                for _ in range(100):
                    if hasattr(server, "pong"):
                        break
                    await asyncio.sleep(0.02)
                await client.close()
                return client, server
        client, server = asyncio.run(run())
        self.assertEqual((server.hellos[0].token, server.hellos[0].peer_name, server.hellos[0].role),
                         ("t0ken", "unit", pl.SAM))
        self.assertEqual(server.hellos[0].session_secret, "")
        self.assertEqual(server.pong, 99)
        self.assertEqual(client.identity, "unit-client")
        self.assertEqual(client.welcome.session_secret, "")

    def test_refused_is_retried_and_reported(self):
        async def run():
            refuse = lambda hello: pl.Frame(refused=pl.Refused(status=pl.UNAUTHENTICATED, reason="wrong token"))
            async with ScriptedServer(refuse) as server:
                client = urslink.Client(server.address, token="x", reconnect_min=0.05, reconnect_max=0.1)
                with self.assertRaises(urslink.PlanetError) as raised:
                    await client.start(timeout=1)
                await client.close()
                return raised.exception, len(server.hellos)
        error, hellos = asyncio.run(run())
        self.assertIn("refused: wrong token", error.message)
        self.assertGreater(hellos, 1)

    def test_heartbeat_timeout_resumes_the_session(self):
        async def run():
            async with ScriptedServer(lambda hello: welcome(hello, timeout_ms=200)) as server:
                client = urslink.Client(server.address, token="x", reconnect_min=0.05, reconnect_max=0.1)
                await client.start(timeout=5)
                for _ in range(200):
                    if len(server.hellos) >= 2:
                        break
                    await asyncio.sleep(0.02)
                error = client.last_error
                await client.close()
                return server.hellos, error
        hellos, error = asyncio.run(run())
        self.assertGreaterEqual(len(hellos), 2)
        self.assertEqual(hellos[1].session_secret, "s" * 64)
        self.assertIn("heartbeat timeout after 200 ms", error)

    def test_oversized_frame_from_the_server_is_refused_before_reading_it(self):
        async def script(server, reader, writer):
            writer.write(struct.pack(">I", 1 << 30))     # announces 1 GiB, sends nothing more
            goodbye = await read_frame(reader, 65536)
            server.goodbye = goodbye.goodbye
            await reader.read()

        async def run():
            async with ScriptedServer(welcome, script) as server:
                client = urslink.Client(server.address, token="x", reconnect_min=1, reconnect_max=1)
                await client.start(timeout=5)
                for _ in range(100):
                    if hasattr(server, "goodbye"):
                        break
                    await asyncio.sleep(0.02)
                error = client.last_error
                await client.close()
                return server, error
        server, error = asyncio.run(run())
        self.assertEqual(server.goodbye.status, pl.PAYLOAD_TOO_LARGE)
        self.assertIn("frame of 1073741824 bytes exceeds the limit of 65536 bytes", server.goodbye.reason)
        self.assertIn("protocol error: frame of 1073741824 bytes", error)

    def test_call_lost_with_the_connection(self):
        async def script(server, reader, writer):
            await read_frame(reader, 65536)   # the Request: close without answering
            writer.close()

        async def run():
            async with ScriptedServer(welcome, script) as server:
                client = urslink.Client(server.address, token="x")
                await client.start(timeout=5)
                with self.assertRaises(urslink.PlanetError) as raised:
                    await client.call("svc", "op", b"")
                await client.close()
                return raised.exception
        error = asyncio.run(run())
        self.assertEqual((error.code, error.message), ("UNAVAILABLE", "connection to server lost"))

    def test_event_of_a_type_without_interface_published_and_received(self):
        types = urslink.Types.from_idl(BASIC_DATA_TYPES)

        async def script(server, reader, writer):
            subscribe = (await read_frame(reader, 65536)).subscribe
            server.send(writer, pl.Frame(subscribe_ack=pl.SubscribeAck(subscription_id=subscribe.subscription_id,
                                                                       status=pl.OK)))
            server.published = (await read_frame(reader, 65536)).publish
            server.send(writer, pl.Frame(publish_ack=pl.PublishAck(publish_id=server.published.publish_id, seq=5,
                                                                   status=pl.OK)))
            server.send(writer, pl.Frame(event=pl.Event(
                subscription_id=subscribe.subscription_id, seq=5, topic=server.published.topic,
                payload=server.published.payload, content_type=server.published.content_type, source="unit-client")))
            await reader.read()

        async def run():
            async with ScriptedServer(welcome, script) as server:
                client = urslink.Client(server.address, token="x")
                await client.start(timeout=5)
                subscription = await client.subscribe("rt/#")
                seq = await client.publish("rt/count", types.message_class("RTC.TimedLong")(data=42))
                event = await subscription.get(timeout=5)
                await client.close()
                return server.published, seq, event
        published, seq, event = asyncio.run(run())
        self.assertEqual((published.topic, published.content_type, seq), ("rt/count", "RTC.TimedLong", 5))
        received = types.decode(event)
        self.assertEqual((received.DESCRIPTOR.full_name, received.data), ("RTC.TimedLong", 42))


if __name__ == "__main__":
    unittest.main()
