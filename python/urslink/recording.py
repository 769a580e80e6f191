"""A space recorded to MCAP and played back (docs/dashboard.md, "Recording and playback").

The recorder is a client of urs-gateway's Foxglove WebSocket endpoint: it subscribes to every
channel the gateway offers — poses, trails, components and their lifecycle states, the catalog,
context, events and the calls made through the gateway with their replies — and writes each
message into an MCAP file (the `mcap` package from PyPI: chunked, zstd-compressed, indexed) under
the channel's topic, with the JSON Schema the gateway advertised (schema encoding "jsonschema",
message encoding "json"), so that Foxglove and Lichtblick open the file as they open the live
connection. log_time is when the message arrived, publish_time the gateway's stamp (the time the
message describes).

Bounded: a file is closed and the next one begun past --max-bytes or --max-seconds (each file
starts with the gateway's latched state: the recorder subscribes again); what waits for the disk
is at most --queue-mib, and what arrives beyond it is dropped and counted (logged, and written in
the file's "urslink.recorder" metadata) instead of being buffered without bound.

The player serves a recording through the same endpoint: it starts `urs-gateway --playback` (or
uses a running one, --gateway) and publishes the recorded channels into it at the recorded pace
(--speed to go faster), so the dashboard, Foxglove and Lichtblick show it as if live; with
--publish-events it also re-publishes the recorded events into a space's CAMUS server.

    python3 -m urslink.recording record --gateway http://127.0.0.1:8765/ --credential-file kr.token -o kr.mcap
    python3 -m urslink.recording play kr.mcap                       # prints the URL to open

(`urs record` and `urs play` run these.) Needs the `mcap` and `websockets` packages."""
import argparse
import asyncio
import glob
import json
import logging
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time

from .client import read_token_file
from .foxglove import FoxgloveClient, GatewayError, login, ws_url

log = logging.getLogger("urslink.recording")

# What a player publishes; the gateway derives /graph, /trails and the per-robot channels itself.
PLAYED_TOPICS = ("/services", "/components", "/poses", "/context", "/events", "/calls")
PROFILE = "urslink"


def _mcap():
    try:
        import mcap.writer  # noqa: F401
        import mcap.reader  # noqa: F401
        return mcap
    except ImportError:
        raise SystemExit("recording needs the `mcap` package: pip install mcap (e.g. pip install 'urslink[mcap]')")


# ---- recording ----------------------------------------------------------------------------------

class FileWriter(threading.Thread):
    """Writes queued messages into MCAP files on a thread of its own, so a slow disk never holds
    the WebSocket: put() never blocks; past `queue_bytes` waiting, messages are dropped and
    counted. Rotation: rotate() (queued, so it lands between the right messages) closes the file
    and begins the next. paths(): every file written so far."""

    def __init__(self, path, numbered, queue_bytes, chunk_bytes, metadata):
        super().__init__(name="mcap-writer", daemon=True)
        self._mcap = _mcap()
        self.path = path
        self.numbered = numbered
        self.queue_bytes = queue_bytes
        self.chunk_bytes = chunk_bytes
        self.metadata = dict(metadata)
        self._queue = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._waiting = 0
        self.dropped = {}          # topic -> messages dropped, this file
        self.dropped_total = 0
        self.written = 0
        self._last_drop_log = 0.0
        self._paths = []
        self._index = 0
        self._file = None
        self._writer = None
        self._channels = {}        # gateway channel id -> MCAP channel id, this file
        self._schemas = {}
        self.file_bytes = 0        # of the current file, as handed to the OS
        self.file_started = time.monotonic()
        self.rotating = False      # a rotation is queued and not yet done
        self.error = None

    def paths(self):
        with self._lock:
            return list(self._paths)

    def put(self, channel, stamp_ns, payload, log_ns):
        size = len(payload)
        with self._lock:
            if self._waiting + size > self.queue_bytes:
                self.dropped[channel["topic"]] = self.dropped.get(channel["topic"], 0) + 1
                self.dropped_total += 1
                now = time.monotonic()
                if now - self._last_drop_log > 5:
                    self._last_drop_log = now
                    log.warning("the disk is slower than the space: %d message(s) dropped so far (%d bytes wait, "
                                "at most %d: --queue-mib)", self.dropped_total, self._waiting, self.queue_bytes)
                return False
            self._waiting += size
        self._queue.put(("message", channel, stamp_ns, payload, log_ns))
        return True

    def rotate(self):
        self.rotating = True
        self._queue.put(("rotate",))

    def finish(self):
        self._queue.put(("finish",))
        self.join()
        if self.error is not None:
            raise self.error

    def run(self):
        try:
            while True:
                item = self._queue.get()
                if item[0] == "finish":
                    self._close()
                    return
                if item[0] == "rotate":
                    self._close()
                    continue
                _, channel, stamp_ns, payload, log_ns = item
                with self._lock:
                    self._waiting -= len(payload)
                self._write(channel, stamp_ns, payload, log_ns)
        except Exception as e:  # the disk failed: recorded, and the recorder stops
            self.error = e
            log.error("writing the recording failed: %s", e)

    def _open(self):
        if self.numbered:
            stem, ext = os.path.splitext(self.path)
            self._index += 1
            path = "%s-%04d%s" % (stem, self._index, ext or ".mcap")
        else:
            path = self.path
        self._file = open(path, "wb")
        self._writer = self._mcap.writer.Writer(self._file, chunk_size=self.chunk_bytes)
        self._writer.start(profile=PROFILE, library="urslink recorder")
        self._writer.add_metadata("urslink.recording", self.metadata)
        self._channels = {}
        self._schemas = {}
        self.file_bytes = 0
        self.file_started = time.monotonic()
        self.rotating = False
        with self._lock:
            self._paths.append(path)
        log.info("recording into %s", path)

    def _write(self, channel, stamp_ns, payload, log_ns):
        if self._writer is None:
            self._open()
        mcap_channel = self._channels.get(channel["id"])
        if mcap_channel is None:
            key = (channel["schemaName"], channel["schema"])
            schema = self._schemas.get(key)
            if schema is None:
                schema = self._writer.register_schema(name=channel["schemaName"], encoding="jsonschema",
                                                      data=channel["schema"].encode())
                self._schemas[key] = schema
            mcap_channel = self._writer.register_channel(topic=channel["topic"], message_encoding="json",
                                                         schema_id=schema)
            self._channels[channel["id"]] = mcap_channel
        self._writer.add_message(channel_id=mcap_channel, log_time=log_ns, publish_time=stamp_ns, data=payload)
        self.written += 1
        self.file_bytes = self._file.tell()

    def _close(self):
        if self._writer is None:
            return
        with self._lock:
            dropped, self.dropped = dict(self.dropped), {}  # each file says what was dropped since the last one
        self._writer.add_metadata("urslink.recorder", {"dropped": json.dumps(dropped, sort_keys=True),
                                                       "dropped_total": str(sum(dropped.values()))})
        self._writer.finish()
        self._file.close()
        self._writer = None
        self._file = None


async def record(args):
    credential = read_token_file(args.credential_file) if args.credential_file else None
    session = args.session or (login(args.gateway, credential) if credential else None)
    numbered = bool(args.max_bytes or args.max_seconds)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    async with FoxgloveClient(ws_url(args.gateway, session)) as fox:
        info = fox.server_info
        metadata = {"space": info.get("metadata", {}).get("space", ""), "gateway": info.get("name", ""),
                    "url": args.gateway, "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        writer = FileWriter(args.output, numbered, args.queue_mib << 20, args.chunk_kib << 10, metadata)
        writer.start()
        wanted = set(args.topic or [])
        subscribed = set()

        async def subscribe_new():
            fresh = [c for c in fox.channels.values()
                     if c["id"] not in subscribed and (not wanted or c["topic"] in wanted)]
            subscribed.update(c["id"] for c in fresh)
            await fox.subscribe(fresh)

        async def resubscribe():
            # Each file starts with the gateway's latched state: subscribe again.
            subscribed.clear()
            await fox.unsubscribe_all()
            await subscribe_new()

        await subscribe_new()
        fox.on_advertise = lambda channels: asyncio.ensure_future(subscribe_new())
        deadline = time.monotonic() + args.duration if args.duration else None

        async def consume():
            async for channel, stamp_ns, payload in fox.messages():
                writer.put(channel, stamp_ns, payload, time.time_ns())
                if writer.error is not None:
                    return
                if numbered and not writer.rotating and writer.written and (
                        writer.file_bytes >= (args.max_bytes or float("inf")) or
                        time.monotonic() - writer.file_started >= (args.max_seconds or float("inf"))):
                    writer.rotate()
                    await resubscribe()

        consumer = asyncio.ensure_future(consume())
        waits = [consumer, asyncio.ensure_future(stop.wait())]
        if deadline:
            waits.append(asyncio.ensure_future(asyncio.sleep(args.duration)))
        await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
        for task in waits:
            task.cancel()
        if fox.closed is not None and not stop.is_set():
            log.warning("the gateway ended the connection: %s %s", *fox.closed)
    writer.finish()
    paths = writer.paths()
    print(json.dumps({"files": paths, "messages": writer.written, "dropped": writer.dropped_total}), flush=True)
    return 0 if paths and writer.error is None else 1


# ---- playback -----------------------------------------------------------------------------------

def recorded_messages(paths):
    """(topic, schema name, log_time ns, data) of the files' messages, in log_time order, file
    after file (rotated files follow each other)."""
    mcap = _mcap()
    for path in paths:
        with open(path, "rb") as f:
            reader = mcap.reader.make_reader(f)
            for schema, channel, message in reader.iter_messages(log_time_order=True):
                yield channel.topic, schema.name if schema else "", message.log_time, message.data


def recording_space(paths):
    mcap = _mcap()
    with open(paths[0], "rb") as f:
        for record in mcap.reader.make_reader(f).iter_metadata():
            if record.name == "urslink.recording":
                return record.metadata.get("space", "")
    return ""


class PlaybackGateway:
    """urs-gateway --playback started for one playback: viewers need no login (--anonymous viewer);
    the player logs in with a credential made for the run. Stopped (SIGTERM) when done."""

    def __init__(self, binary, space, listen, web_dir=None):
        self.dir = tempfile.mkdtemp(prefix="urs-play-")
        self.token = os.urandom(16).hex()
        token_file = os.path.join(self.dir, "player.token")
        with open(token_file, "w") as f:
            f.write(self.token + "\n")
        port_file = os.path.join(self.dir, "port")
        argv = [binary, "--playback", "--space", space or "recording", "--listen", listen, "--token-file", token_file,
                "--anonymous", "viewer", "--port-file", port_file]
        if web_dir:
            argv += ["--web-dir", web_dir]
        self.process = subprocess.Popen(argv)
        deadline = time.monotonic() + 20
        while not os.path.exists(port_file):
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise SystemExit("urs-gateway --playback did not start (exit %s)" % self.process.poll())
            time.sleep(0.05)
        host = listen.rsplit(":", 1)[0]
        with open(port_file) as f:
            self.url = "http://%s:%s/" % (host, f.read().strip())

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()


class EventPublisher:
    """Re-publishes recorded events into a space's CAMUS server: each payload encoded again as its
    type (described by the server's registry), JSON payloads as JSON, unknown ones from base64."""

    def __init__(self, client, prefix):
        self.client = client
        self.prefix = prefix
        self.classes = {}
        self.published = 0

    async def _class(self, type_name):
        if type_name not in self.classes:
            try:
                self.classes[type_name] = (await self.client.describe(type=type_name)).message_class(type_name)
            except Exception as e:  # not described by this space: the event is skipped, and said so
                log.warning("event type %s is not known to the space: its events are not re-published (%s)",
                            type_name, e)
                self.classes[type_name] = None
        return self.classes[type_name]

    async def publish(self, event):
        import base64
        from google.protobuf import json_format
        payload = event.get("payload", "null")
        value = json.loads(payload) if isinstance(payload, str) else payload
        content_type = event.get("content_type", "")
        if isinstance(value, dict) and set(value) == {"base64"}:
            data = base64.b64decode(value["base64"])
        elif content_type in ("", "application/json"):
            data = json.dumps(value).encode()
        else:
            cls = await self._class(content_type)
            if cls is None:
                return
            data = json_format.ParseDict(value, cls()).SerializeToString()
        await self.client.publish(self.prefix + event["topic"], data, content_type)
        self.published += 1


async def play(args):
    paths = sorted(p for pattern in args.files for p in (glob.glob(pattern) or [pattern]))
    for path in paths:
        if not os.path.exists(path):
            raise SystemExit("no recording '%s'" % path)
    gateway = None
    if args.events_only:
        return await _play_into(args, paths, None, None)
    if args.gateway:
        http_url = args.gateway
        credential = read_token_file(args.credential_file) if args.credential_file else None
    else:
        binary = args.gateway_bin or os.environ.get("URS_GATEWAY_BIN") or "urs-gateway"
        gateway = PlaybackGateway(binary, recording_space(paths), args.listen, args.web_dir)
        http_url, credential = gateway.url, gateway.token
    try:
        if args.port_file:
            with open(args.port_file + ".tmp", "w") as f:
                f.write(http_url.rstrip("/").rsplit(":", 1)[1])
            os.replace(args.port_file + ".tmp", args.port_file)
        print("playing %s on %s (dashboard; Foxglove: %s)" % (", ".join(paths), http_url, ws_url(http_url)), flush=True)
        return await _play_into(args, paths, http_url, credential)
    finally:
        if gateway is not None:
            gateway.stop()


async def _play_into(args, paths, http_url, credential):
    """Plays `paths` into the gateway at `http_url` (None: only the events, into the space)."""
    session = login(http_url, credential) if credential else None
    events = None
    if args.publish_events:
        from .client import Client
        events = EventPublisher(Client(args.server, token_file=args.token_file), args.events_prefix)
        await events.client.start(timeout=10)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    played = skipped = 0
    try:
        async with (FoxgloveClient(ws_url(http_url, session)) if http_url else _NoGateway()) as fox:
            channels = {}
            while not stop.is_set():
                first_log = None
                started = time.monotonic()
                for topic, schema_name, log_time, data in recorded_messages(paths):
                    if stop.is_set():
                        break
                    if topic not in PLAYED_TOPICS or (http_url is None and topic != "/events"):
                        skipped += 1
                        continue
                    if first_log is None:
                        first_log = log_time
                    if args.speed > 0:
                        due = started + (log_time - first_log) / 1e9 / args.speed
                        delay = due - time.monotonic()
                        if delay > 0:
                            try:
                                await asyncio.wait_for(stop.wait(), delay)
                                break
                            except asyncio.TimeoutError:
                                pass
                    if http_url is not None:
                        if topic not in channels:
                            channels[topic] = await fox.advertise(topic, schema_name)
                        await fox.publish(channels[topic], data)
                    played += 1
                    if events is not None and topic == "/events":
                        await events.publish(json.loads(data))
                    if fox.closed is not None:
                        raise GatewayError("the gateway ended the connection: %s %s" % fox.closed)
                if not args.loop:
                    break
            print(json.dumps({"played": played, "skipped": skipped,
                              "events_published": events.published if events else 0}), flush=True)
            if args.then == "serve" and http_url is not None and not stop.is_set():
                print("the recording has been played; still serving its last state (Ctrl-C ends)", flush=True)
                await stop.wait()
    finally:
        if events is not None:
            await events.client.close()
    return 0


# ---- command line -------------------------------------------------------------------------------

class _NoGateway:
    """In place of the gateway's client when only events are re-published."""
    closed = None

    async def __aenter__(self):
        return self

    async def __aexit__(self, *exc):
        return False


def main(argv=None):
    parser = argparse.ArgumentParser(prog="urs", description="Record a space to MCAP, or play a recording back")
    commands = parser.add_subparsers(dest="command", required=True)
    rec = commands.add_parser("record", help="record a gateway's channels into MCAP files")
    rec.add_argument("--gateway", default=os.environ.get("URS_GATEWAY", "http://127.0.0.1:8765/"),
                     help="the gateway's HTTP URL (env URS_GATEWAY)")
    rec.add_argument("--credential-file", default=os.environ.get("URS_TOKEN_FILE"),
                     help="a credential of the space (a viewer's is enough)")
    rec.add_argument("--session", help="a session id from the dashboard instead of a credential")
    rec.add_argument("-o", "--output", required=True, help="the MCAP file (numbered FILE-0001.mcap... when rotating)")
    rec.add_argument("--topic", action="append", help="record only this topic (repeatable; default: every channel)")
    rec.add_argument("--duration", type=float, default=0, help="stop after SECONDS (default: at SIGINT/SIGTERM)")
    rec.add_argument("--max-bytes", type=int, default=0, help="begin a new file past this size")
    rec.add_argument("--max-seconds", type=float, default=0, help="begin a new file past this age")
    rec.add_argument("--queue-mib", type=int, default=64, help="what may wait for the disk before messages are dropped")
    rec.add_argument("--chunk-kib", type=int, default=1024, help="MCAP chunk size")
    pl = commands.add_parser("play", help="serve a recording through a gateway's Foxglove endpoint")
    pl.add_argument("files", nargs="+", help="MCAP file(s) (a rotated recording: all its files, or a glob)")
    pl.add_argument("--speed", type=float, default=1.0, help="times the recorded pace (0: as fast as possible)")
    pl.add_argument("--loop", action="store_true", help="start again at the end")
    pl.add_argument("--then", choices=("serve", "exit"), default="serve",
                    help="at the end: keep serving the last state until Ctrl-C, or exit")
    pl.add_argument("--listen", default="127.0.0.1:8765",
                    help="HOST:PORT of the playback gateway started here (port 0: any free one; see --port-file)")
    pl.add_argument("--port-file", help="written with the port once serving (scripts, tests)")
    pl.add_argument("--gateway-bin", help="urs-gateway to start (env URS_GATEWAY_BIN; default: on PATH)")
    pl.add_argument("--web-dir", help="the dashboard's files, if not the gateway's default")
    pl.add_argument("--gateway", help="publish into this running gateway (urs-gateway --playback) instead")
    pl.add_argument("--credential-file", help="with --gateway: an operator's credential of it")
    pl.add_argument("--publish-events", action="store_true", help="re-publish the recorded events into a space")
    pl.add_argument("--server", default=os.environ.get("URS_SERVER", "127.0.0.1:7600"),
                    help="with --publish-events: the space's CAMUS server")
    pl.add_argument("--token-file", default=os.environ.get("URS_TOKEN_FILE"),
                    help="with --publish-events: a credential that may publish")
    pl.add_argument("--events-prefix", default="", help="with --publish-events: put the events under this topic prefix")
    pl.add_argument("--events-only", action="store_true",
                    help="with --publish-events: only re-publish the events (no gateway serves the recording)")
    pl.add_argument("--log-level", default="info")
    rec.add_argument("--log-level", default="info")
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if args.command == "record":
        if not args.credential_file and not args.session:
            parser.error("record: give --credential-file (or --session)")
        runner = record
    else:
        if args.publish_events and not args.token_file:
            parser.error("play --publish-events: give --token-file")
        if args.events_only and not args.publish_events:
            parser.error("play --events-only: give --publish-events")
        runner = play
    try:
        return asyncio.run(runner(args))
    except GatewayError as e:
        print("urs %s: %s" % (args.command, e), file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
