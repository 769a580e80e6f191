"""The asyncio Planet client (docs/planet.md; the behaviour of the C++ urs::planet::Client).

One Client keeps one session with a CAMUS server: it connects, authenticates with its credential's
token, and reconnects by itself with exponential backoff, presenting the session secret of the
last Welcome so that the server resumes the session. On each new session it restores, in this
order: its service registrations, its subscriptions (resuming after the last event delivered),
its unacknowledged publishes, then the calls queued while it was disconnected."""
import asyncio
import collections
import inspect
import logging
import random
import time

from google.protobuf import json_format, struct_pb2

from ._proto import camus_pb2 as cm
from ._proto import planet_pb2 as pl
from .errors import PlanetError, UserException
from .interface import Interface
from .wire import MIN_CHUNK_BYTES, ProtocolError, Reassembler, encode, read_frame

log = logging.getLogger("urslink")

CLIENT = pl.CLIENT
SAM = pl.SAM
OPERATOR = pl.OPERATOR
SEND_BUFFER_BYTES = 4 << 20   # written but not yet taken by the socket, before senders wait
_ROLES = {"client": pl.CLIENT, "sam": pl.SAM, "operator": pl.OPERATOR}


def _role(value):
    if isinstance(value, str):
        try:
            return _ROLES[value.lower()]
        except KeyError:
            raise ValueError("role '%s' is not one of client, sam, operator" % value) from None
    return int(value)


def read_token_file(path):
    """The token in a token file (docs/security.md): its content without surrounding white space."""
    with open(path) as f:
        token = f.read().strip()
    if not token:
        raise ValueError("token file '%s' is empty" % path)
    return token


class _Call:
    __slots__ = ("frame", "label", "future", "deadline_ms", "expires", "sent", "oneway")

    def __init__(self, frame, label, future, deadline_ms, oneway):
        self.frame = frame          # the Request frame until sent
        self.label = label          # "service.operation"
        self.future = future        # None for oneways
        self.deadline_ms = deadline_ms
        self.expires = 0.0         # monotonic time of the local deadline (or of the queue timeout)
        self.sent = False
        self.oneway = oneway


class Subscription:
    """Events of one pattern. Iterate it (`async for event in subscription`) or give the client a
    callback; `last_seq` is the seq of the last event delivered, `dropped` counts events dropped
    because the iterator's queue (`max_pending`) was full."""

    def __init__(self, client, sid, pattern, callback, last_seq, max_pending):
        self.client = client
        self.id = sid
        self.pattern = pattern
        self.callback = callback
        self.last_seq = last_seq
        self.dropped = 0
        self.queue = asyncio.Queue(max_pending)
        self.ack = None             # future of the pending SubscribeAck
        self.task = None            # delivers to the callback, in order
        self.closed = False

    def _deliver(self, event):
        if self.queue.full():
            self.queue.get_nowait()
            self.dropped += 1
            if self.dropped == 1 or self.dropped % 1000 == 0:
                log.warning("urslink: subscription '%s' is not read fast enough: %d events dropped",
                            self.pattern, self.dropped)
        self.queue.put_nowait(event)

    def __aiter__(self):
        return self

    async def __anext__(self):
        if self.closed and self.queue.empty():
            raise StopAsyncIteration
        event = await self.queue.get()
        if event is None:
            raise StopAsyncIteration
        return event

    async def get(self, timeout=None):
        """The next event; asyncio.TimeoutError after `timeout` seconds."""
        event = await asyncio.wait_for(self.queue.get(), timeout)
        if event is None:
            raise PlanetError(pl.UNAVAILABLE, "subscription to '%s' closed" % self.pattern)
        return event

    async def close(self):
        """Unsubscribes."""
        await self.client.unsubscribe(self)


class ServiceProxy:
    """Calls the operations of one service by name: `await proxy.setTarget(celsius=21.5)` returns
    the reply message; a declared exception raises UserException with its decoded value."""

    def __init__(self, client, service, interface):
        self.client = client
        self.service = service
        self.interface = interface

    async def call(self, operation, request=None, *, deadline_ms=None, **fields):
        method = self.interface.methods.get(operation)
        if method is None:
            raise PlanetError(pl.UNKNOWN_OPERATION, "interface %s has no operation '%s'"
                              % (self.interface.name, operation))
        if request is None:
            request = method.request(**fields)
        elif isinstance(request, dict):
            request = json_format.ParseDict(request, method.request())
        payload = request.SerializeToString()
        if method.oneway:
            await self.client.call(self.service, operation, payload, oneway=True)
            return None
        try:
            answer = await self.client.call(self.service, operation, payload, deadline_ms=deadline_ms)
        except UserException as raised:
            raise self.interface.decode_exception(raised.type_name, raised.payload, raised.message) from None
        return method.reply.FromString(answer)

    def __getattr__(self, operation):
        if operation.startswith("__") or operation not in self.interface.methods:
            raise AttributeError("%s (%s) has no operation '%s'" % (self.service, self.interface.name, operation))

        async def invoke(request=None, **fields):
            return await self.call(operation, request, **fields)
        return invoke


class Client:
    """A Planet client: `async with Client("127.0.0.1:7400", token_file="client.token") as c:`.

    server      "HOST:PORT"
    token       the credential's token, or token_file: a file holding it (docs/security.md)
    peer_name   self-declared name, for display (logs, ServiceInfo.peer_name)
    role        the least role needed: "client", "sam" (to serve agents) or "operator"
    ssl         passed to asyncio.open_connection (an ssl.SSLContext, or None for plain TCP)
    deadline_ms default deadline of calls; None: send 0 = the service's advertised deadline,
                else the server's default (as the C++ client and `urs call` do)
    connect_timeout, reconnect_min, reconnect_max, queue_timeout: seconds (as ClientOptions)
    max_queued  calls + publishes waiting for a connection, beyond which they fail UNAVAILABLE
    """

    def __init__(self, server="127.0.0.1:7400", *, token=None, token_file=None, peer_name="python",
                 role="client", ssl=None, server_hostname=None, deadline_ms=None, connect_timeout=2.0,
                 reconnect_min=0.05, reconnect_max=2.0, queue_timeout=10.0, max_queued=10000,
                 max_message_bytes=64 << 20, chunk_bytes=64 << 10, max_pending_events=10000):
        host, sep, port = server.rpartition(":")
        if not sep or not port.isdigit():
            raise ValueError("server '%s' is not HOST:PORT" % server)
        self.host = host.strip("[]") or "127.0.0.1"
        self.port = int(port)
        self.target = server
        if token_file is not None:
            token = read_token_file(token_file)
        self._token = token or ""
        self.peer_name = peer_name
        self.role_asked = _role(role)
        self.ssl = ssl
        self.server_hostname = server_hostname
        self.default_deadline_ms = deadline_ms
        if connect_timeout <= 0 or reconnect_min <= 0 or reconnect_max < reconnect_min or queue_timeout <= 0:
            raise ValueError("invalid Client options: need connect_timeout > 0, 0 < reconnect_min <= reconnect_max, "
                             "queue_timeout > 0")
        if chunk_bytes < MIN_CHUNK_BYTES:
            raise ValueError("chunk_bytes %d is below the minimum of %d" % (chunk_bytes, MIN_CHUNK_BYTES))
        self.connect_timeout = connect_timeout
        self.reconnect_min = reconnect_min
        self.reconnect_max = reconnect_max
        self.queue_timeout = queue_timeout
        self.max_queued = max_queued
        self.max_message_bytes = max_message_bytes
        self.chunk_bytes = chunk_bytes
        self.max_pending_events = max_pending_events

        self.welcome = None         # of the current (or last) session, session_secret cleared
        self.resumed = False        # whether the server resumed the previous session
        self.sessions = 0           # Welcomes received
        self.last_error = ""
        self._secret = ""           # never logged
        self._open = False
        self._writer = None
        self._send_chunk = chunk_bytes
        self._max_frame = chunk_bytes
        self._send_limit = None
        self._message_ids = 0
        self._next_call_id = 1
        self._calls = {}            # call id -> _Call (sent and queued)
        self._queue = collections.deque()   # call ids not sent yet, in order
        self._next_publish_id = 1
        self._unacked = collections.OrderedDict()  # publish id -> (Publish, future)
        self._next_subscription_id = 1
        self._subscriptions = {}
        self._registrations = collections.OrderedDict()  # name -> RegisterRequest
        self._agents = {}           # service name -> Agent
        self._connected = None      # asyncio.Event, set while a session is open
        self._runner = None
        self._stopping = False
        self._tasks = set()
        self._last_rx = 0.0

    # ---- life cycle ------------------------------------------------------------------------------

    async def start(self, wait=True, timeout=None):
        """Starts connecting (and reconnecting). With `wait`, returns once the first session is
        open, or raises PlanetError UNAVAILABLE with the last error after `timeout` seconds
        (default: queue_timeout); the client then keeps trying until close()."""
        if self._runner is None:
            self._connected = asyncio.Event()
            self._runner = asyncio.get_running_loop().create_task(self._run())
        if wait:
            await self.wait_connected(timeout)
        return self

    async def wait_connected(self, timeout=None):
        if self._connected is None:
            raise PlanetError(pl.UNAVAILABLE, "client not started: await start() first")
        try:
            await asyncio.wait_for(self._connected.wait(), timeout if timeout is not None else self.queue_timeout)
        except asyncio.TimeoutError:
            raise PlanetError(pl.UNAVAILABLE, "no session with %s: %s" % (self.target, self.last_error or "timeout")) \
                from None

    async def close(self):
        """Says Goodbye, stops reconnecting; what is pending fails UNAVAILABLE "client stopped"."""
        if self._stopping:
            return
        self._stopping = True
        if self._writer is not None and self._open:
            self._send(pl.Frame(goodbye=pl.Goodbye(status=pl.OK, reason="client stopped")))
        if self._runner is not None:
            self._runner.cancel()
            try:
                await self._runner
            except (asyncio.CancelledError, Exception):
                pass
        self._close_writer()
        self._fail_all("client stopped")
        for task in list(self._tasks):
            task.cancel()
        for sub in list(self._subscriptions.values()):
            self._end_subscription(sub)
        self._subscriptions.clear()

    async def __aenter__(self):
        try:
            return await self.start()
        except BaseException:
            await self.close()      # no session: stop retrying, the block does not run
            raise

    async def __aexit__(self, *exc):
        await self.close()

    @property
    def connected(self):
        return self._open

    @property
    def identity(self):
        return self.welcome.identity if self.welcome else ""

    @property
    def role(self):
        return self.welcome.role if self.welcome else pl.ROLE_UNSPECIFIED

    @property
    def space(self):
        return self.welcome.space if self.welcome else ""

    # ---- calls -----------------------------------------------------------------------------------

    async def call(self, service, operation, payload=b"", *, deadline_ms=None, oneway=False):
        """Calls SERVICE.OPERATION with the serialized request `payload` (bytes or a message);
        returns the serialized reply. Raises PlanetError (UserException for a declared exception).

        deadline_ms None takes the client's default; 0 (or None without a default) sends none: the
        server applies the service's advertised deadline. A oneway call returns None once sent or
        queued."""
        if not isinstance(payload, (bytes, bytearray)):
            payload = payload.SerializeToString()
        if deadline_ms is None:
            deadline_ms = self.default_deadline_ms or 0
        loop = asyncio.get_running_loop()
        if self._stopping:
            raise PlanetError(pl.UNAVAILABLE, "client stopped")
        if not self._open and self._queued() >= self.max_queued:
            raise PlanetError(pl.UNAVAILABLE, self._queue_full_message())
        request = pl.Request(service=service, operation=operation, payload=bytes(payload), oneway=oneway)
        future = None if oneway else loop.create_future()
        self._start_call(pl.Frame(request=request), "%s.%s" % (service, operation), future, max(0, deadline_ms))
        await self._backpressure()
        if future is None:
            return None
        status, message, answer, exception_type = await future
        if status == pl.OK:
            return answer
        if status == pl.USER_EXCEPTION:
            raise UserException(exception_type, answer, message)
        raise PlanetError(status, message)

    async def oneway(self, service, operation, payload=b""):
        await self.call(service, operation, payload, oneway=True)

    def _start_call(self, frame, label, future, deadline_ms, jump_queue=False):
        cid = self._next_call_id
        self._next_call_id += 1
        frame.request.call_id = cid
        call = _Call(frame, label, future, deadline_ms, frame.request.oneway)
        # Without a deadline the local timer bounds only the wait for a connection: once sent, the
        # server answers by the service's deadline (docs/planet.md, "Calls and deadlines").
        wait = deadline_ms / 1000.0 if deadline_ms > 0 else self.queue_timeout
        call.expires = time.monotonic() + wait
        if future is not None:
            handle = asyncio.get_running_loop().call_later(wait, self._on_deadline, cid)
            future.add_done_callback(lambda _f, h=handle: h.cancel())
        self._calls[cid] = call
        if self._open and (not self._queue or jump_queue) and self._send_call(cid):
            return cid
        self._queue.append(cid)
        return cid

    def _send_call(self, cid):
        call = self._calls.get(cid)
        if call is None:
            return True         # expired while queued
        request = call.frame.request
        if call.oneway or call.deadline_ms == 0:
            request.deadline_ms = 0
        else:
            request.deadline_ms = max(1, int((call.expires - time.monotonic()) * 1000))
        size = call.frame.ByteSize()
        if self._send_limit and size > self._send_limit:
            del self._calls[cid]
            self._resolve(call, pl.PAYLOAD_TOO_LARGE, "request of %d bytes to %s exceeds the server's "
                          "max_message_bytes %d" % (size, call.label, self._send_limit))
            return True
        if not self._send(call.frame):
            return False
        call.frame = None
        if call.oneway:
            del self._calls[cid]
        else:
            call.sent = True
        return True

    def _on_deadline(self, cid):
        call = self._calls.get(cid)
        if call is None:
            return
        if call.deadline_ms == 0:
            if call.sent:
                return          # the server's answer bounds it now
            status = pl.UNAVAILABLE
            message = "%s not sent: no connection to %s within %d ms" % (call.label, self.target,
                                                                        self.queue_timeout * 1000)
        else:
            status = pl.DEADLINE_EXCEEDED
            message = "no reply from %s within %d ms" % (call.label, call.deadline_ms)
        del self._calls[cid]
        try:
            self._queue.remove(cid)
        except ValueError:
            pass
        self._resolve(call, status, message)

    @staticmethod
    def _resolve(call, status, message="", payload=b"", exception_type=""):
        if call.future is not None and not call.future.done():
            call.future.set_result((status, message, payload, exception_type))

    def _queued(self):
        return len(self._queue) + len(self._unacked)

    def _queue_full_message(self):
        return "not connected to %s and the queue of %d is full" % (self.target, self.max_queued)

    # ---- built-in services -----------------------------------------------------------------------

    async def _builtin(self, service, operation, request, reply_type, deadline_ms=None):
        answer = await self.call(service, operation, request.SerializeToString(), deadline_ms=deadline_ms)
        return reply_type.FromString(answer)

    async def list_services(self, pattern=""):
        """The registry's services whose name matches the glob `pattern` (camus.ServiceInfo list)."""
        reply = await self._builtin("camus.registry", "List", cm.ListRequest(pattern=pattern), cm.ListReply)
        return list(reply.services)

    async def describe(self, service=None, *, interface=None, type=None):
        """The Interface of a registered service (or of an interface, or the one holding a type)."""
        request = cm.DescribeRequest(service=service or "", interface=interface or "", type=type or "")
        reply = await self._builtin("camus.registry", "Describe", request, cm.DescribeReply)
        return Interface(reply.descriptor_set, reply.interface)

    async def proxy(self, service, interface=None):
        """A ServiceProxy calling `service` by operation name (described by the server if no
        Interface is given)."""
        if interface is None:
            interface = await self.describe(service)
        return ServiceProxy(self, service, interface)

    async def context_get(self, key):
        """The context entry KEY (camus.ContextEntry); its value as Python: `value_of(entry)`."""
        return await self._builtin("camus.context", "Get", cm.ContextGetRequest(key=key), cm.ContextEntry)

    async def context_set(self, key, value, *, ttl_ms=0, source=""):
        """Sets KEY to a JSON-like Python value (needs role operator); returns the new entry."""
        request = cm.ContextSetRequest(key=key, ttl_ms=ttl_ms, source=source)
        json_format.ParseDict(value, request.value)
        return await self._builtin("camus.context", "Set", request, cm.ContextEntry)

    async def context_delete(self, key):
        await self._builtin("camus.context", "Delete", cm.ContextDeleteRequest(key=key), cm.ContextDeleteReply)

    async def context_ls(self, pattern=""):
        reply = await self._builtin("camus.context", "List", cm.ContextListRequest(pattern=pattern),
                                    cm.ContextListReply)
        return list(reply.entries)

    async def task_define(self, name, yaml):
        reply = await self._builtin("camus.tasks", "Define", cm.TaskDefinition(name=name, yaml=yaml),
                                    cm.TaskDefineReply)
        return reply.task

    async def task_run(self, name="", *, yaml=""):
        return await self._builtin("camus.tasks", "Run", cm.TaskRunRequest(name=name, yaml=yaml), cm.TaskRun)

    async def task_status(self, run_id="", *, name=""):
        return await self._builtin("camus.tasks", "Status", cm.TaskStatusRequest(run_id=run_id, name=name),
                                   cm.TaskRun)

    async def task_cancel(self, run_id):
        return await self._builtin("camus.tasks", "Cancel", cm.TaskCancelRequest(run_id=run_id), cm.TaskRun)

    async def task_list(self):
        return await self._builtin("camus.tasks", "List", cm.TaskListRequest(), cm.TaskListReply)

    # ---- events ----------------------------------------------------------------------------------

    def publish_nowait(self, topic, payload=b"", content_type=""):
        """Queues a Publish (a message payload sets content_type to its type's full name); returns
        a future of the seq the server assigned (PlanetError if it refused). Kept and resent after
        a reconnect until acknowledged."""
        if not isinstance(payload, (bytes, bytearray)):
            content_type = content_type or payload.DESCRIPTOR.full_name
            payload = payload.SerializeToString()
        if self._stopping:
            raise PlanetError(pl.UNAVAILABLE, "client stopped")
        if self._queued() >= self.max_queued:
            raise PlanetError(pl.UNAVAILABLE, self._queue_full_message())
        publish = pl.Publish(publish_id=self._next_publish_id, topic=topic, payload=bytes(payload),
                             content_type=content_type)
        if self._open and self._send_limit and publish.ByteSize() + 16 > self._send_limit:
            raise PlanetError(pl.PAYLOAD_TOO_LARGE, "publish of %d bytes on '%s' exceeds the server's "
                              "max_message_bytes %d" % (publish.ByteSize() + 16, topic, self._send_limit))
        self._next_publish_id += 1
        future = asyncio.get_running_loop().create_future()
        self._unacked[publish.publish_id] = (publish, future)
        if self._open:
            self._send(pl.Frame(publish=publish))
        return future

    async def publish(self, topic, payload=b"", content_type=""):
        """Publishes and waits for the server's acknowledgement; returns the event's seq."""
        future = self.publish_nowait(topic, payload, content_type)
        await self._backpressure()
        return await future

    async def subscribe(self, pattern, callback=None, *, resume_after_seq=0):
        """Subscribes to `pattern` ("*" one level, trailing "#" any levels). Returns a Subscription
        (iterate it), or calls `callback(event)` (a function or coroutine function) in order.
        Waits for the SubscribeAck when connected; raises PlanetError if the server refuses."""
        sid = self._next_subscription_id
        self._next_subscription_id += 1
        sub = Subscription(self, sid, pattern, callback, resume_after_seq, self.max_pending_events)
        self._subscriptions[sid] = sub
        if callback is not None:
            sub.task = self._spawn(self._deliver_to_callback(sub))
        if self._open:
            sub.ack = asyncio.get_running_loop().create_future()
            self._send_subscribe(sub)
            status, message = await sub.ack
            if status != pl.OK:
                self._subscriptions.pop(sid, None)
                self._end_subscription(sub)
                raise PlanetError(status, message)
        return sub

    async def unsubscribe(self, sub):
        if self._subscriptions.pop(sub.id, None) is None:
            return
        if self._open:
            self._send(pl.Frame(unsubscribe=pl.Unsubscribe(subscription_id=sub.id)))
        self._end_subscription(sub)

    def _end_subscription(self, sub):
        sub.closed = True
        if sub.queue.full():
            sub.queue.get_nowait()
        sub.queue.put_nowait(None)

    def _send_subscribe(self, sub):
        self._send(pl.Frame(subscribe=pl.Subscribe(subscription_id=sub.id, pattern=sub.pattern,
                                                   resume_after_seq=sub.last_seq)))

    async def _deliver_to_callback(self, sub):
        while True:
            event = await sub.queue.get()
            if event is None:
                return
            try:
                result = sub.callback(event)
                if inspect.isawaitable(result):
                    await result
            except Exception:
                log.exception("urslink: event handler for '%s' raised", event.topic)

    # ---- serving agents --------------------------------------------------------------------------

    async def serve(self, name, agent, *, deadline_ms=0, properties=None):
        """Registers `agent` (an urslink.Agent) as service `name` and answers the Requests routed
        to it. Needs role sam. The registration is restored on every reconnect until unserve().
        deadline_ms is the service's advertised deadline (0: the server's default)."""
        info = cm.ServiceInfo(name=name, interface=agent.interface.name, deadline_ms=deadline_ms)
        for key, value in (properties or {}).items():
            info.properties[key] = value
        registration = cm.RegisterRequest(service=info, descriptor_set=agent.interface.descriptor_set)
        self._agents[name] = agent
        agent._attach(self, name)
        self._registrations[name] = registration
        if not self._open:
            return
        try:
            await self._register(registration)
        except PlanetError:
            self._registrations.pop(name, None)
            self._agents.pop(name, None)
            raise

    async def unserve(self, name):
        self._agents.pop(name, None)
        if self._registrations.pop(name, None) is not None and self._open:
            await self._builtin("camus.registry", "Unregister", cm.UnregisterRequest(name=name), cm.UnregisterReply)

    async def _register(self, registration, jump_queue=False):
        future = asyncio.get_running_loop().create_future()
        frame = pl.Frame(request=pl.Request(service="camus.registry", operation="Register",
                                            payload=registration.SerializeToString()))
        self._start_call(frame, "camus.registry.Register", future, 0, jump_queue)
        status, message, _, _ = await future
        if status != pl.OK:
            raise PlanetError(status, "registering service '%s': %s" % (registration.service.name, message))

    async def _reregister(self, registration):
        try:
            await self._register(registration, jump_queue=True)
        except PlanetError as error:
            log.error("urslink: re-registering service '%s' failed: %s", registration.service.name, error)

    def _on_request(self, request, writer):
        agent = self._agents.get(request.service)
        if agent is None:
            if not request.oneway:
                self._reply(writer, request.call_id, pl.UNKNOWN_SERVICE,
                            "no service named '%s' on this client" % request.service)
            return
        self._spawn(self._answer(agent, request, writer))

    async def _answer(self, agent, request, writer):
        status, message, payload, exception_type = await agent._dispatch(request)
        if not request.oneway:
            self._reply(writer, request.call_id, status, message, payload, exception_type)
            await self._backpressure()

    def _reply(self, writer, call_id, status, message="", payload=b"", exception_type=""):
        if writer is not self._writer or not self._open:
            return              # that connection is gone; the caller got PROVIDER_GONE
        self._send(pl.Frame(reply=pl.Reply(call_id=call_id, status=status, message=message, payload=payload,
                                           exception_type=exception_type)))

    def _spawn(self, coroutine):
        task = asyncio.get_running_loop().create_task(coroutine)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    # ---- the connection --------------------------------------------------------------------------

    def _send(self, frame):
        """Writes `frame` (chunked when over the session's chunk size); False if not connected."""
        writer = self._writer
        if writer is None or writer.is_closing():
            return False
        writer.write(encode(frame, self._send_chunk, self._new_message_id))
        return True

    async def _backpressure(self):
        """Waits while more than SEND_BUFFER_BYTES are waiting to be written to the socket."""
        writer = self._writer
        if writer is not None and writer.transport.get_write_buffer_size() > SEND_BUFFER_BYTES:
            try:
                await writer.drain()
            except ConnectionError:
                pass            # the read loop notices and reconnects

    def _new_message_id(self):
        self._message_ids += 1
        return self._message_ids

    def _close_writer(self):
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.close()
            except Exception:
                pass

    async def _run(self):
        failures = 0
        while not self._stopping:
            was_open = False
            try:
                reader = await self._connect()
                was_open = True
                failures = 0
                await self._read_loop(reader)
            except asyncio.CancelledError:
                raise
            except (OSError, asyncio.IncompleteReadError, asyncio.TimeoutError, ProtocolError, _Ended) as error:
                self._note_failure(error)
            finally:
                self._session_lost(was_open)
            if self._stopping:
                return
            failures += 1
            delay = min(self.reconnect_max, self.reconnect_min * (2 ** min(failures - 1, 20)))
            delay = max(self.reconnect_min, random.uniform(delay / 2, delay))
            await asyncio.sleep(delay)

    def _note_failure(self, error):
        if isinstance(error, _Ended):
            self.last_error = str(error)
        elif isinstance(error, asyncio.TimeoutError):
            self.last_error = "cannot connect to %s: no Welcome within %d ms" % (self.target,
                                                                                 self.connect_timeout * 1000)
        elif isinstance(error, asyncio.IncompleteReadError):
            self.last_error = "connection to %s closed by the server" % self.target
        elif isinstance(error, ProtocolError):
            self.last_error = "protocol error: %s" % error
            self._send(pl.Frame(goodbye=pl.Goodbye(status=error.status, reason=str(error))))
        else:
            self.last_error = "cannot connect to %s: %s" % (self.target, error.strerror or error)
        log.info("urslink: %s", self.last_error)

    async def _connect(self):
        """TCP connect, Hello, Welcome: within connect_timeout. Returns the reader."""
        async def handshake():
            kwargs = {"ssl": self.ssl}
            if self.ssl is not None and self.server_hostname is not None:
                kwargs["server_hostname"] = self.server_hostname
            reader, writer = await asyncio.open_connection(self.host, self.port, limit=1 << 20, **kwargs)
            try:
                self._writer = writer
                self._send_chunk = self.chunk_bytes
                self._send(pl.Frame(hello=pl.Hello(version=1, token=self._token, peer_name=self.peer_name,
                                                   role=self.role_asked, session_secret=self._secret)))
                frame = await read_frame(reader, self.chunk_bytes)
            except BaseException:
                self._close_writer()
                raise
            return reader, frame
        reader, frame = await asyncio.wait_for(handshake(), self.connect_timeout)
        kind = frame.WhichOneof("body")
        if kind == "refused":
            log.error("urslink: %s refused the connection (%s): %s", self.target,
                      pl.Status.Name(frame.refused.status), frame.refused.reason)
            raise _Ended("refused: " + frame.refused.reason)
        if kind == "goodbye":
            raise _Ended("goodbye: " + frame.goodbye.reason)
        if kind != "welcome":
            raise ProtocolError(pl.BAD_ARGUMENTS, "expected Welcome or Refused from %s, got %s" % (self.target, kind))
        self._on_welcome(frame.welcome)
        return reader

    def _on_welcome(self, welcome):
        resumed = bool(self._secret) and self._secret == welcome.session_secret
        self.resumed = resumed
        self._secret = welcome.session_secret
        welcome.session_secret = ""
        self.welcome = welcome
        self._send_limit = welcome.max_message_bytes or None
        if welcome.chunk_bytes >= MIN_CHUNK_BYTES:
            self._send_chunk = min(self.chunk_bytes, welcome.chunk_bytes)
        self._max_frame = min(max(self.chunk_bytes, welcome.chunk_bytes), self.max_message_bytes)
        self._open = True
        self.sessions += 1
        log.info("urslink: connected to %s (space '%s', server instance %s) as %s (role %s), %s session",
                 self.target, welcome.space, welcome.server_instance, welcome.identity,
                 pl.Role.Name(welcome.role), "resumed" if resumed else "new")
        # Restore, in this order: registrations, subscriptions, unacknowledged publishes, queued calls.
        for registration in self._registrations.values():
            self._spawn(self._reregister(registration))
        for sub in self._subscriptions.values():
            self._send_subscribe(sub)
        for publish_id, (publish, future) in list(self._unacked.items()):
            if self._send_limit and publish.ByteSize() + 16 > self._send_limit:
                del self._unacked[publish_id]
                if not future.done():
                    future.set_exception(PlanetError(pl.PAYLOAD_TOO_LARGE, "publish on '%s' exceeds the server's "
                                                     "max_message_bytes %d" % (publish.topic, self._send_limit)))
                continue
            self._send(pl.Frame(publish=publish))
        while self._queue and self._open:
            if not self._send_call(self._queue[0]):
                break
            self._queue.popleft()
        self._connected.set()

    async def _read_loop(self, reader):
        """Reads the session's frames; a server silent for Welcome.heartbeat_timeout_ms is dead
        (checked by a watchdog, so that reading a frame costs no timer)."""
        timeout_ms = self.welcome.heartbeat_timeout_ms
        self._last_rx = time.monotonic()
        reading = asyncio.ensure_future(self._read_frames(reader))
        try:
            while True:
                done, _ = await asyncio.wait({reading}, timeout=timeout_ms / 4000.0 if timeout_ms else None)
                if done:
                    return reading.result()
                if time.monotonic() - self._last_rx > timeout_ms / 1000.0:
                    raise _Ended("heartbeat timeout after %d ms" % timeout_ms)
        finally:
            reading.cancel()

    async def _read_frames(self, reader):
        reassembler = Reassembler(self.max_message_bytes)
        while True:
            frame = reassembler.feed(await read_frame(reader, self._max_frame))
            self._last_rx = time.monotonic()   # any frame, chunks included, is a sign of life
            if frame is not None:
                self._on_frame(frame)

    def _on_frame(self, frame):
        kind = frame.WhichOneof("body")
        if kind == "reply":
            reply = frame.reply
            call = self._calls.get(reply.call_id)
            if call is None or not call.sent:
                return          # late or unknown
            del self._calls[reply.call_id]
            self._resolve(call, reply.status, reply.message, reply.payload, reply.exception_type)
        elif kind == "event":
            event = frame.event
            sub = self._subscriptions.get(event.subscription_id)
            if sub is None or event.seq <= sub.last_seq:
                return          # unsubscribed meanwhile, or a duplicate replayed after a resume
            sub.last_seq = event.seq
            sub._deliver(event)
        elif kind == "request":
            self._on_request(frame.request, self._writer)
        elif kind == "ping":
            self._send(pl.Frame(pong=pl.Pong(nonce=frame.ping.nonce)))
        elif kind == "publish_ack":
            ack = frame.publish_ack
            entry = self._unacked.pop(ack.publish_id, None)
            if entry is None:
                return          # a duplicate ack after a resend
            publish, future = entry
            if future.done():
                return
            if ack.status == pl.OK:
                future.set_result(ack.seq)
            else:
                log.warning("urslink: server refused publish %d on '%s': %s: %s", ack.publish_id, publish.topic,
                            pl.Status.Name(ack.status), ack.message)
                future.set_exception(PlanetError(ack.status, ack.message))
                future.exception()  # retrieved: publish_nowait callers may ignore it
        elif kind == "subscribe_ack":
            self._on_subscribe_ack(frame.subscribe_ack)
        elif kind == "goodbye":
            log.warning("urslink: %s said goodbye (%s): %s", self.target, pl.Status.Name(frame.goodbye.status),
                        frame.goodbye.reason)
            raise _Ended("goodbye: " + frame.goodbye.reason)

    def _on_subscribe_ack(self, ack):
        sub = self._subscriptions.get(ack.subscription_id)
        if sub is None:
            return
        waiter, sub.ack = sub.ack, None
        if ack.status != pl.OK:
            log.error("urslink: subscription to '%s' refused: %s: %s", sub.pattern, pl.Status.Name(ack.status),
                      ack.message)
        else:
            if sub.last_seq > 0 and ack.oldest_retained_seq > sub.last_seq + 1:
                log.warning("urslink: events %d..%d on '%s' are no longer retained by %s; they are lost",
                            sub.last_seq + 1, ack.oldest_retained_seq - 1, sub.pattern, self.target)
            if sub.last_seq == 0:
                sub.last_seq = ack.last_seq     # "only new events": after what was current
            elif ack.last_seq < sub.last_seq:
                log.warning("urslink: %s restarted its event sequence (now %d, had %d); resuming there",
                            self.target, ack.last_seq, sub.last_seq)
                sub.last_seq = ack.last_seq
        if waiter is not None and not waiter.done():
            waiter.set_result((ack.status, ack.message))

    def _session_lost(self, was_open):
        self._open = False
        if self._connected is not None:
            self._connected.clear()
        self._close_writer()
        if not was_open:
            return
        if not self._stopping:
            log.warning("urslink: session with %s lost: %s", self.target, self.last_error)
        for cid, call in list(self._calls.items()):
            if call.sent:
                del self._calls[cid]
                self._resolve(call, pl.UNAVAILABLE, "client stopped" if self._stopping else "connection to server lost")
        for sub in self._subscriptions.values():
            waiter, sub.ack = sub.ack, None
            if waiter is not None and not waiter.done():
                waiter.set_result((pl.OK, ""))  # restored with the next session

    def _fail_all(self, message):
        for cid, call in list(self._calls.items()):
            self._resolve(call, pl.UNAVAILABLE, message)
        self._calls.clear()
        self._queue.clear()
        for publish, future in self._unacked.values():
            if not future.done():
                future.set_exception(PlanetError(pl.UNAVAILABLE, message))
                future.exception()
        self._unacked.clear()


class _Ended(Exception):
    """The server ended the session (Refused, Goodbye) or went silent."""


def value_of(entry):
    """The Python value of a camus.ContextEntry (or a google.protobuf.Value)."""
    value = entry.value if hasattr(entry, "key") else entry
    return json_format.MessageToDict(value) if isinstance(value, struct_pb2.Value) else value
