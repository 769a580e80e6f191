"""A client of urs-gateway's Foxglove WebSocket endpoint (subprotocol foxglove.websocket.v1, the
public specification foxglove/ws-protocol docs/spec.md; docs/dashboard.md): what the recorder reads
and the player publishes through. Needs the `websockets` package (Debian python3-websockets).

    session = login("http://127.0.0.1:8765/", credential)          # POST /api/login
    async with FoxgloveClient(ws_url("http://127.0.0.1:8765/", session)) as fox:
        channels = await fox.wait_channels({"/poses"})              # topic -> channel dict
        await fox.subscribe(channels.values())
        async for channel, stamp_ns, payload in fox.messages():     # payload: the JSON bytes
            ...

Every wait is bounded by the caller (asyncio.wait_for); a server's Status of error level is kept
in `statuses` and logged."""
import asyncio
import json
import logging
import struct
import urllib.error
import urllib.parse
import urllib.request

log = logging.getLogger("urslink.foxglove")

SUBPROTOCOL = "foxglove.websocket.v1"
OP_MESSAGE_DATA = 0x01
OP_CLIENT_MESSAGE_DATA = 0x01


class GatewayError(Exception):
    """The gateway refused: a login, a connection, or what a client sent (its message says why)."""


def _post(http_url, path, body, timeout):
    """POST JSON to the gateway; the JSON answer (a GatewayError says why not)."""
    request = urllib.request.Request(urllib.parse.urljoin(http_url, path), data=json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"}, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=timeout) as response:
            return json.loads(response.read())
    except urllib.error.HTTPError as e:
        raise GatewayError("%s refused (%d): %s" % (path, e.code, e.read().decode(errors="replace"))) from None
    except (OSError, ValueError) as e:
        raise GatewayError("%s at %s: %s" % (path, http_url, e)) from None


def login(http_url, credential, timeout=10):
    """POST /api/login with `credential`; returns the session id."""
    answer = _post(http_url, "/api/login", {"credential": credential}, timeout)
    if "session" not in answer:
        raise GatewayError("/api/login answered no session: %s" % answer)
    return answer["session"]


def logout(http_url, session, timeout=10):
    """POST /api/logout naming the session: it ends, and so do its WebSocket connections."""
    return _post(http_url, "/api/logout", {"session": session}, timeout)


def ws_url(http_url, session=None):
    """The WebSocket URL of a gateway's HTTP URL, with ?session= when given."""
    parts = urllib.parse.urlsplit(http_url)
    scheme = "wss" if parts.scheme == "https" else "ws"
    query = urllib.parse.urlencode({"session": session}) if session else ""
    return urllib.parse.urlunsplit((scheme, parts.netloc, "/", query, ""))


class FoxgloveClient:
    """One connection. `channels` (id -> channel) follows advertise / unadvertise; `server_info` is
    the first message. messages() yields what arrives on the subscriptions in order."""

    def __init__(self, url, max_size=16 << 20, queue_messages=1024):
        self.url = url
        self.max_size = max_size
        self.channels = {}
        self.services = {}
        self.server_info = None
        self.statuses = []
        self._subscriptions = {}   # subscription id -> channel
        self._next_subscription = 1
        self._next_client_channel = 1
        self._queue = asyncio.Queue(maxsize=queue_messages)
        self._changed = asyncio.Event()
        self._ws = None
        self._pump = None
        self.closed = None         # (code, reason) once the connection ended
        self.on_advertise = None   # called with the channels of each advertise message

    async def __aenter__(self):
        await self.connect()
        return self

    async def __aexit__(self, *exc):
        await self.close()

    async def connect(self):
        import websockets  # only the gateway's clients need it
        try:
            self._ws = await websockets.connect(self.url, subprotocols=[SUBPROTOCOL], max_size=self.max_size)
        except websockets.InvalidStatusCode as e:
            raise GatewayError("the gateway refused the connection (HTTP %d): log in first" % e.status_code) from None
        self._pump = asyncio.ensure_future(self._read())
        await self._until(lambda: self.server_info is not None, "serverInfo")

    async def close(self):
        if self._ws is not None:
            await self._ws.close()
        if self._pump is not None:
            await asyncio.gather(self._pump, return_exceptions=True)

    async def _until(self, condition, what, timeout=None):
        while not condition():
            if self.closed is not None:
                raise GatewayError("the connection ended (%s %s) while waiting for %s" % (self.closed + (what,)))
            self._changed.clear()
            await asyncio.wait_for(self._changed.wait(), timeout)

    async def _read(self):
        import websockets
        try:
            async for message in self._ws:
                if isinstance(message, str):
                    self._on_text(json.loads(message))
                elif message and message[0] == OP_MESSAGE_DATA and len(message) >= 13:
                    subscription, stamp = struct.unpack_from("<IQ", message, 1)
                    channel = self._subscriptions.get(subscription)
                    if channel is not None:
                        # Backpressure: a full queue holds this reader (the gateway's own bound then
                        # applies); a recorder drains it into a bounded queue of its own.
                        await self._queue.put((channel, stamp, bytes(message[13:])))
                self._changed.set()
        except websockets.ConnectionClosed:
            pass
        finally:
            code = getattr(self._ws, "close_code", None)
            self.closed = (code, getattr(self._ws, "close_reason", "") or "")
            self._changed.set()
            await self._queue.put(None)

    def _on_text(self, message):
        op = message.get("op")
        if op == "serverInfo":
            self.server_info = message
        elif op == "advertise":
            for channel in message.get("channels", []):
                self.channels[channel["id"]] = channel
            if self.on_advertise is not None:
                self.on_advertise(message.get("channels", []))
        elif op == "unadvertise":
            for channel_id in message.get("channelIds", []):
                self.channels.pop(channel_id, None)
        elif op == "advertiseServices":
            for service in message.get("services", []):
                self.services[service["id"]] = service
        elif op == "unadvertiseServices":
            for service_id in message.get("serviceIds", []):
                self.services.pop(service_id, None)
        elif op == "status":
            self.statuses.append(message)
            if message.get("level", 0) >= 2:
                log.warning("gateway: %s", message.get("message"))

    def by_topic(self):
        return {channel["topic"]: channel for channel in self.channels.values()}

    async def wait_channels(self, topics, timeout=None):
        """Waits until every topic in `topics` is advertised; returns topic -> channel."""
        await asyncio.wait_for(self._until(lambda: set(topics) <= set(self.by_topic()), "channels %s" % sorted(topics)),
                               timeout)
        return self.by_topic()

    async def subscribe(self, channels):
        subscriptions = []
        for channel in channels:
            number = self._next_subscription
            self._next_subscription += 1
            self._subscriptions[number] = channel
            subscriptions.append({"id": number, "channelId": channel["id"]})
        if subscriptions:
            await self._ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    async def unsubscribe_all(self):
        """Ends every subscription; what still arrives on them is ignored."""
        numbers = list(self._subscriptions)
        self._subscriptions.clear()
        if numbers:
            await self._ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": numbers}))

    async def messages(self):
        """(channel, stamp ns, payload bytes) in order of arrival, until the connection ends."""
        while True:
            item = await self._queue.get()
            if item is None:
                return
            yield item

    async def advertise(self, topic, schema_name, encoding="json"):
        """A client channel (clientPublish); returns its id."""
        if self.server_info is None or "clientPublish" not in self.server_info.get("capabilities", []):
            raise GatewayError("this gateway takes no published messages (start it with --playback)")
        number = self._next_client_channel
        self._next_client_channel += 1
        await self._ws.send(json.dumps({"op": "advertise", "channels": [
            {"id": number, "topic": topic, "encoding": encoding, "schemaName": schema_name}]}))
        return number

    async def publish(self, channel_id, payload):
        await self._ws.send(struct.pack("<BI", OP_CLIENT_MESSAGE_DATA, channel_id) + payload)
