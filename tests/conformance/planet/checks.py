"""The checks: one function per MUST of docs/planet.md, grouped by section.

Each check gets the Suite (connections, credentials, the diagnostic service's types) and raises
Fail with what it expected and saw, or Skip with why it cannot run against this server.
"""
import os
import re
import time

import camus_pb2 as cm
import planet_pb2 as pl
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

from .wire import Closed, Connection

CHECKS = []


class Fail(Exception):
    pass


class Skip(Exception):
    pass


def check(section, text):
    def register(fn):
        CHECKS.append((section, text, fn))
        return fn
    return register


def expect(condition, what, seen=None):
    if not condition:
        raise Fail(what + ("" if seen is None else "; saw: %s" % " ".join(str(seen).split())[:300]))


class Suite:
    def __init__(self, host, port, tokens, diag, limits, handshake_timeout_s, tls=None):
        self.host, self.port = host, port
        self.tls = tls                  # ssl.SSLContext, or None for plain TCP
        self.tokens = tokens            # role word -> token (client always present)
        self.diag = diag
        self.limits = limits
        self.handshake_timeout_s = handshake_timeout_s
        self._types = None
        self._open = []
        self.unique = "%d-%d" % (os.getpid(), int(time.time()))

    def close_all(self):
        for conn in self._open:
            conn.close()
        self._open = []

    def connect(self):
        conn = Connection(self.host, self.port, tls=self.tls)
        self._open.append(conn)
        return conn

    def token(self, role):
        if role not in self.tokens:
            raise Skip("no --%s-token-file given" % role)
        return self.tokens[role]

    def open(self, role="client", name="conformance", hello_role=pl.CLIENT, secret=""):
        conn = self.connect()
        first = conn.hello(self.token(role), name, hello_role, secret)
        expect(first is not None and first.WhichOneof("body") == "welcome",
               "a Welcome for the %s credential" % role, first)
        return conn

    def credentialed(self):
        """True if the server has credentials (an open server calls everyone 'anonymous')."""
        conn = self.open()
        return conn.welcome.identity != "anonymous"

    def call(self, conn, service, operation, payload=b"", deadline_ms=10000, call_id=1, oneway=False):
        frame = pl.Frame()
        r = frame.request
        r.call_id, r.service, r.operation, r.payload = call_id, service, operation, payload
        r.deadline_ms, r.oneway = deadline_ms, oneway
        conn.send(frame)
        if oneway:
            return None
        reply = conn.expect("reply", timeout=max(15.0, deadline_ms / 1000.0 + 5), match=lambda x: x.call_id == call_id)
        expect(reply is not None, "a Reply to call %d (%s.%s)" % (call_id, service, operation))
        return reply.reply

    def register(self, conn, name, interface, call_id=1):
        """Registers `name` on `conn`; returns the Reply."""
        registration = cm.RegisterRequest()
        registration.service.name = name
        registration.service.interface = interface
        return self.call(conn, "camus.registry", "Register", registration.SerializeToString(), call_id=call_id)

    def diag_types(self):
        """The diagnostic service's messages, built from camus.registry Describe."""
        if self._types is not None:
            return self._types
        if not self.diag:
            raise Skip("no --diag service given")
        conn = self.open(name="conformance-describe")
        request = cm.DescribeRequest(service=self.diag)
        reply = self.call(conn, "camus.registry", "Describe", request.SerializeToString())
        if reply.status == pl.UNKNOWN_SERVICE:
            raise Skip("the server has no service '%s'" % self.diag)
        expect(reply.status == pl.OK, "Describe of %s answers OK" % self.diag, reply)
        described = cm.DescribeReply.FromString(reply.payload)
        files = descriptor_pb2.FileDescriptorSet.FromString(described.descriptor_set)
        pool = descriptor_pool.DescriptorPool()
        for f in files.file:
            pool.Add(f)
        service = pool.FindServiceByName(described.interface)
        factory = message_factory.MessageFactory(pool)
        make = getattr(message_factory, "GetMessageClass", None) or factory.GetPrototype
        types = {"interface": described.interface}
        for method in service.methods:
            types[method.name] = (make(method.input_type), make(method.output_type))
        if "Failure" not in types:
            package = described.interface.rsplit(".", 1)[0]
            try:
                types["Failure"] = make(pool.FindMessageTypeByName(package + ".Failure"))
            except KeyError:
                pass
        self._types = types
        return types

    def diag_request(self, operation, **fields):
        types = self.diag_types()
        if operation not in types:
            raise Skip("%s (%s) has no operation %s" % (self.diag, types["interface"], operation))
        return types[operation][0](**fields).SerializeToString()


def expect_goodbye(conn, status):
    """The server says Goodbye with `status` and closes the connection."""
    answer = conn.expect("goodbye")
    expect(answer is not None and answer.goodbye.status == status, "Goodbye %s" % pl.Status.Name(status), answer)
    expect(conn.closed_by_server(), "the connection closed")


def expect_refused(answer, status, what):
    """`answer` (the first frame after a Hello) is Refused with `status`; returns the Refused."""
    expect(answer is not None and answer.WhichOneof("body") == "refused" and answer.refused.status == status,
           "Refused %s %s" % (pl.Status.Name(status), what), answer)
    return answer.refused


def deep_topic(levels, word="a"):
    return "/".join([word] * levels)


# ---- 3. Handshake and versioning ----------------------------------------------------------------

@check("3", "a Welcome carries version 1, the space, the instance, heartbeats, limits, identity, role and a session secret")
def welcome_fields(s):
    conn = s.open()
    w = conn.welcome
    expect(w.version == 1, "Welcome.version 1", w.version)
    expect(w.space != "", "a space name")
    expect(w.server_instance != "", "a server_instance")
    expect(0 < w.heartbeat_interval_ms < w.heartbeat_timeout_ms, "0 < heartbeat_interval_ms < heartbeat_timeout_ms", w)
    expect(w.max_message_bytes > 0 and w.chunk_bytes >= 512, "max_message_bytes > 0 and chunk_bytes >= 512", w)
    expect(re.fullmatch("[0-9a-f]{64}", w.session_secret) is not None, "a session_secret of 64 hex digits",
           len(w.session_secret))
    expect(w.identity != "", "an identity")
    expect(w.role in (pl.CLIENT, pl.SAM, pl.OPERATOR), "a role", w.role)


@check("3", "the first frame must be Hello: anything else gets Goodbye BAD_ARGUMENTS and the connection closes")
def first_frame_hello(s):
    conn = s.connect()
    conn.ping(1)
    expect_goodbye(conn, pl.BAD_ARGUMENTS)


def expect_hello_limit(conn):
    """Before Welcome, over the Hello limit: Goodbye PAYLOAD_TOO_LARGE naming max_hello_bytes, then close."""
    answer = conn.expect("goodbye")
    expect(answer is not None and answer.goodbye.status == pl.PAYLOAD_TOO_LARGE and
           "(max_hello_bytes)" in answer.goodbye.reason, "Goodbye PAYLOAD_TOO_LARGE naming max_hello_bytes", answer)
    expect(conn.closed_by_server(), "the connection closed")


@check("3", "before Welcome a Chunk is refused: Goodbye PAYLOAD_TOO_LARGE naming max_hello_bytes, close")
def chunk_before_welcome(s):
    conn = s.connect()
    hello = pl.Frame()
    hello.hello.version, hello.hello.token, hello.hello.peer_name = 1, s.token("client"), "conformance"
    data = hello.SerializeToString()
    frame = pl.Frame()
    frame.chunk.message_id, frame.chunk.total_bytes, frame.chunk.data, frame.chunk.last = 1, len(data), data, True
    conn.send(frame)
    expect_hello_limit(conn)


@check("3", "before Welcome a frame over max_hello_bytes is refused PAYLOAD_TOO_LARGE before its body is read")
def large_frame_before_welcome(s):
    conn = s.connect()
    size = s.limits["max_hello_bytes"] + 1
    conn.send_raw(size.to_bytes(4, "big") + b"\0" * 64)
    expect_hello_limit(conn)


@check("3", "a version other than 1 is refused (Refused INTERNAL naming the version) and the connection closes")
def version_mismatch(s):
    conn = s.connect()
    refused = expect_refused(conn.hello(s.token("client"), version=2), pl.INTERNAL, "for version 2")
    expect("version 2" in refused.reason, "a reason naming version 2", refused)
    expect(conn.closed_by_server(), "the connection closed")


@check("3", "no Hello within the handshake timeout: Goodbye DEADLINE_EXCEEDED, close")
def handshake_timeout(s):
    conn = s.connect()
    answer = conn.expect("goodbye", timeout=s.handshake_timeout_s)
    expect(answer is not None and answer.goodbye.status == pl.DEADLINE_EXCEEDED, "Goodbye DEADLINE_EXCEEDED", answer)
    expect(conn.closed_by_server(), "then the connection closed")


@check("3", "a second Hello on an open session is a protocol error: Goodbye BAD_ARGUMENTS, close")
def second_hello(s):
    conn = s.open()
    answer = conn.hello(s.token("client"))
    expect(answer is not None and answer.WhichOneof("body") == "goodbye" and answer.goodbye.status == pl.BAD_ARGUMENTS,
           "Goodbye BAD_ARGUMENTS", answer)
    expect(conn.closed_by_server(), "the connection closed after a second Hello")


@check("3", "the Hello is checked in order: version, peer_name, role value, credential, role; the first failure answers")
def hello_check_order(s):
    conn = s.connect()
    refused = expect_refused(conn.hello("wrong", peer_name="", role=7, version=2), pl.INTERNAL, "for the version first")
    conn = s.connect()
    expect_refused(conn.hello("wrong", peer_name="", role=7), pl.BAD_ARGUMENTS, "for the peer_name second")
    conn = s.connect()
    refused = expect_refused(conn.hello("wrong", role=7), pl.BAD_ARGUMENTS, "for the role value third")
    expect("Hello.role 7" in refused.reason, "a reason naming Hello.role 7", refused)
    if not s.credentialed():
        raise Skip("an open server checks no credential")
    conn = s.connect()
    expect_refused(conn.hello("wrong", role=pl.OPERATOR), pl.UNAUTHENTICATED, "for the credential before the role")


@check("3", "Hello.role 0 (unset) asks for the least role: the Welcome names the credential's role")
def hello_role_zero(s):
    conn = s.connect()
    answer = conn.hello(s.token("client"), role=0)
    expect(answer is not None and answer.WhichOneof("body") == "welcome", "a Welcome", answer)
    expect(answer.welcome.role in (pl.CLIENT, pl.SAM, pl.OPERATOR), "the credential's role", answer.welcome.role)


@check("1", "a zero-length frame is a protocol error before and after the handshake: Goodbye BAD_ARGUMENTS, close")
def zero_length_frame(s):
    for conn in (s.connect(), s.open()):
        conn.send_raw(b"\0\0\0\0")
        expect_goodbye(conn, pl.BAD_ARGUMENTS)


@check("3", "a Goodbye as the first frame: the server closes the connection without answering")
def goodbye_first(s):
    conn = s.connect()
    conn.send(pl.Frame(goodbye=pl.Goodbye(status=pl.OK, reason="never mind")))
    try:
        answer = conn.recv(5)
    except Closed:
        answer = None
    expect(answer is None, "no answer", answer)
    expect(conn.closed_by_server(), "the connection closed")


@check("3", "frames sent right after the Hello, before the Welcome, are handled once the session is open")
def pipelined_after_hello(s):
    conn = s.connect()
    hello = pl.Frame()
    hello.hello.version, hello.hello.token, hello.hello.peer_name = 1, s.token("client"), "conformance"
    hello.hello.role = pl.CLIENT
    request = pl.Frame()
    r = request.request
    r.call_id, r.service, r.operation = 7, "camus.registry", "List"
    r.payload = cm.ListRequest(pattern="camus.*").SerializeToString()
    conn.send_all([hello, request])
    first = conn.recv(10)
    expect(first is not None and first.WhichOneof("body") == "welcome", "the Welcome first", first)
    reply = conn.expect("reply", match=lambda x: x.call_id == 7)
    expect(reply is not None and reply.reply.status == pl.OK, "then the Reply to the pipelined call", reply)


@check("3", "peer_name must be 1..128 bytes of letters, digits and . _ - @ : /, not camus-server (Refused BAD_ARGUMENTS)")
def peer_name_validated(s):
    for name in ["", "x" * 129, "with space", "camus-server", "new\nline"]:
        conn = s.connect()
        expect_refused(conn.hello(s.token("client"), peer_name=name), pl.BAD_ARGUMENTS, "for peer_name %r" % name)
    s.open(name="sam@robot1:a/b_c-d.e")


@check("3", "peer_name letters are ASCII letters: a non-ASCII letter is refused BAD_ARGUMENTS")
def peer_name_ascii(s):
    conn = s.connect()
    expect_refused(conn.hello(s.token("client"), peer_name="caf\u00e9"), pl.BAD_ARGUMENTS, "for peer_name 'caf\u00e9'")


# ---- 4. Authentication, identity and roles -------------------------------------------------------

@check("4.1", "a missing token is refused UNAUTHENTICATED; a wrong one 'wrong token'")
def tokens_required(s):
    if not s.credentialed():
        raise Skip("the server is open (no credentials)")
    conn = s.connect()
    expect_refused(conn.hello(""), pl.UNAUTHENTICATED, "without a token")
    conn = s.connect()
    refused = expect_refused(conn.hello(s.token("client") + "-not"), pl.UNAUTHENTICATED, "for a wrong token")
    expect(refused.reason == "wrong token", "the reason 'wrong token'", refused)
    expect(conn.closed_by_server(), "the connection closed")


@check("4.2", "a Hello asking a role above its credential's is Refused PERMISSION_DENIED")
def role_above_credential(s):
    conn = s.open()
    if conn.welcome.role != pl.CLIENT:
        raise Skip("the --token-file credential has role %s, not CLIENT" % pl.Role.Name(conn.welcome.role))
    conn = s.connect()
    expect_refused(conn.hello(s.token("client"), role=pl.SAM), pl.PERMISSION_DENIED, "for role SAM")


@check("4.2", "operations beyond the session's role get PERMISSION_DENIED (Register for a client, context Set for a sam)")
def operations_need_roles(s):
    conn = s.open()
    if conn.welcome.role != pl.CLIENT:
        raise Skip("the --token-file credential has role %s, not CLIENT" % pl.Role.Name(conn.welcome.role))
    reply = s.register(conn, "conformance.denied-" + s.unique, "conformance.Nothing")
    expect(reply.status == pl.PERMISSION_DENIED, "Register by a client: PERMISSION_DENIED", reply)
    entry = cm.ContextSetRequest(key="conformance/denied")
    entry.value.number_value = 1
    reply = s.call(conn, "camus.context", "Set", entry.SerializeToString(), call_id=2)
    expect(reply.status == pl.PERMISSION_DENIED, "context Set by a client: PERMISSION_DENIED", reply)
    sam = s.open("sam", hello_role=pl.SAM)
    reply = s.call(sam, "camus.context", "Set", entry.SerializeToString())
    expect(reply.status == pl.PERMISSION_DENIED, "context Set by a sam: PERMISSION_DENIED", reply)


@check("4.2", "server topics (registry/, context/, task/) are published by the server alone: PERMISSION_DENIED")
def server_topics(s):
    conn = s.open()
    for i, topic in enumerate(["registry/x", "context/x/y", "task/t/r1", "registry"]):
        frame = pl.Frame()
        frame.publish.publish_id = i + 1
        frame.publish.topic = topic
        conn.send(frame)
        ack = conn.expect("publish_ack", match=lambda a, n=i + 1: a.publish_id == n)
        expect(ack is not None and ack.publish_ack.status == pl.PERMISSION_DENIED,
               "PublishAck PERMISSION_DENIED on %s" % topic, ack)


@check("4.2", "Event.source is the publisher's identity (Welcome.identity)")
def event_source(s):
    conn = s.open(name="looks-like-someone-else")
    topic = "conformance/source/" + s.unique
    subscribe(conn, 1, topic)
    publish(conn, 1, topic, b"x", wait=False)  # the Event comes before the PublishAck
    event = conn.expect("event")
    expect(event is not None, "the event")
    expect(event.event.source == conn.welcome.identity, "source %r" % conn.welcome.identity, event.event.source)


@check("4.2", "a context entry's source is the setter's identity; its declared source is the origin")
def context_source(s):
    conn = s.open("operator")
    entry = cm.ContextSetRequest(key="conformance/source-" + s.unique, source="camus-server")
    entry.value.string_value = "x"
    reply = s.call(conn, "camus.context", "Set", entry.SerializeToString())
    expect(reply.status == pl.OK, "context Set by an operator: OK", reply)
    got = cm.ContextEntry.FromString(reply.payload)
    expect(got.source == conn.welcome.identity and got.origin == "camus-server",
           "source %r, origin 'camus-server'" % conn.welcome.identity, got)
    s.call(conn, "camus.context", "Delete", cm.ContextDeleteRequest(key=entry.key).SerializeToString(), call_id=2)


@check("4.3", "the session secret resumes the session with the same credential; the old connection gets Goodbye UNAVAILABLE")
def secret_resumes(s):
    first = s.open()
    secret = first.welcome.session_secret
    again = s.open(secret=secret)
    expect(again.welcome.session_secret == secret, "the same secret back (a resumed session)")
    goodbye = first.expect("goodbye")
    expect(goodbye is not None and goodbye.goodbye.status == pl.UNAVAILABLE,
           "Goodbye UNAVAILABLE on the previous connection", goodbye)


@check("4.3", "an unknown secret, or a secret with another credential, gets a new session")
def secret_needs_its_credential(s):
    stranger = s.open(secret="0" * 64)
    expect(stranger.welcome.session_secret != "0" * 64, "a new secret for an unknown one")
    owner = s.open()
    if "sam" not in s.tokens and "operator" not in s.tokens:
        raise Skip("needs a second credential (--sam-token-file or --operator-token-file)")
    other = "sam" if "sam" in s.tokens else "operator"
    thief = s.open(other, secret=owner.welcome.session_secret)
    expect(thief.welcome.session_secret != owner.welcome.session_secret, "a new session for another credential")
    expect(owner.expect("goodbye", timeout=1.0) is None, "the owner's connection left open")


@check("12", "a service name with an empty level (/x, a//b, x/) is refused BAD_ARGUMENTS: it could not be announced")
def service_name_levels(s):
    conn = s.open(role="sam", hello_role=pl.SAM)
    for i, name in enumerate(["/conformance", "conformance//x", "conformance/"]):
        reply = s.register(conn, name, "URS.Diagnostic", call_id=i + 1)
        expect(reply.status == pl.BAD_ARGUMENTS and "empty level" in reply.message,
               "BAD_ARGUMENTS naming the empty level for %r" % name, reply)


@check("4.3", "a resumed session keeps its registrations; a session of another credential cannot register or "
              "remove them; one of the same credential provides the service too and removes only itself")
def registrations_belong_to_the_session(s):
    name = "conformance.svc-" + s.unique
    sam = s.open("sam", name="conformance-sam", hello_role=pl.SAM)
    reply = s.register(sam, name, "conformance.Echo")
    expect(reply.status == pl.OK, "Register by a sam: OK", reply)
    if s.credentialed():
        other = s.open("operator", name="conformance-sam", hello_role=pl.OPERATOR)
        reply = s.register(other, name, "conformance.Echo")
        expect(reply.status == pl.ALREADY_EXISTS, "a session of another credential: ALREADY_EXISTS", reply)
        reply = s.call(other, "camus.registry", "Unregister", cm.UnregisterRequest(name=name).SerializeToString(),
                       call_id=2)
        expect(reply.status == pl.PERMISSION_DENIED, "its Unregister: PERMISSION_DENIED", reply)
    replica = s.open("sam", name="conformance-replica", hello_role=pl.SAM)
    reply = s.register(replica, name, "conformance.Other")
    expect(reply.status == pl.ALREADY_EXISTS, "the same credential with another interface: ALREADY_EXISTS", reply)
    reply = s.register(replica, name, "conformance.Echo", call_id=2)
    expect(reply.status == pl.OK, "the same credential, another session: OK, a second provider", reply)
    listed = cm.ListReply.FromString(
        s.call(replica, "camus.registry", "List", cm.ListRequest(pattern=name).SerializeToString(), call_id=3).payload)
    expect(len(listed.services) == 1 and [p.peer_name for p in listed.services[0].providers] ==
           ["conformance-sam", "conformance-replica"], "one service with both providers, the first one first", listed)
    reply = s.call(replica, "camus.registry", "Unregister", cm.UnregisterRequest(name=name).SerializeToString(),
                   call_id=4)
    expect(reply.status == pl.OK, "the second provider unregisters itself: OK", reply)
    resumed = s.open("sam", name="conformance-sam", hello_role=pl.SAM, secret=sam.welcome.session_secret)
    reply = s.register(resumed, name, "conformance.Echo")
    expect(reply.status == pl.OK, "the resumed session re-registers: OK", reply)
    # Calls reach it under a server call id; the reply goes back under the caller's.
    caller = s.open()
    frame = pl.Frame()
    frame.request.call_id, frame.request.service, frame.request.operation = 77, name, "say"
    frame.request.payload, frame.request.deadline_ms = b"hi", 5000
    caller.send(frame)
    routed = resumed.expect("request")
    expect(routed is not None and routed.request.service == name and routed.request.payload == b"hi",
           "the Request routed to the provider", routed)
    answer = pl.Frame()
    answer.reply.call_id = routed.request.call_id
    answer.reply.status = pl.OK
    answer.reply.payload = b"hi back"
    resumed.send(answer)
    reply = caller.expect("reply")
    expect(reply is not None and reply.reply.call_id == 77 and reply.reply.payload == b"hi back",
           "the provider's Reply under the caller's id 77", reply)
    s.call(resumed, "camus.registry", "Unregister", cm.UnregisterRequest(name=name).SerializeToString(), call_id=3)


# ---- 8. Heartbeats ------------------------------------------------------------------------------

@check("8", "a Ping is answered by a Pong with its nonce, and the server pings an open session")
def heartbeats(s):
    conn = s.open()
    conn.ping(424242)
    pong = conn.expect("pong", match=lambda p: p.nonce == 424242)
    expect(pong is not None, "Pong{424242}")
    conn.answer_pings = False
    ping = conn.expect("ping", timeout=3 * conn.welcome.heartbeat_interval_ms / 1000.0 + 1)
    expect(ping is not None, "a Ping within 3 heartbeat intervals")


# ---- 9. Calls and deadlines ---------------------------------------------------------------------

@check("9", "an unknown service is UNKNOWN_SERVICE, answered under the caller's call_id")
def unknown_service(s):
    conn = s.open()
    reply = s.call(conn, "conformance.nothing-" + s.unique, "x", call_id=987654321)
    expect(reply.status == pl.UNKNOWN_SERVICE and reply.call_id == 987654321, "UNKNOWN_SERVICE for call 987654321",
           reply)


@check("9", "a call reaches the service and its reply comes back; an unknown operation is UNKNOWN_OPERATION")
def echo_call(s):
    conn = s.open()
    types = s.diag_types()
    reply = s.call(conn, s.diag, "echo", s.diag_request("echo", text="conformance"))
    expect(reply.status == pl.OK, "echo OK", reply)
    expect(types["echo"][1].FromString(reply.payload).result == "conformance", "the text echoed")
    reply = s.call(conn, s.diag, "no_such_operation", call_id=2)
    expect(reply.status == pl.UNKNOWN_OPERATION, "UNKNOWN_OPERATION", reply)


@check("9", "a declared exception comes back as USER_EXCEPTION with exception_type and the exception")
def user_exception(s):
    conn = s.open()
    types = s.diag_types()
    reply = s.call(conn, s.diag, "fail", s.diag_request("fail", reason="on purpose", code=7))
    expect(reply.status == pl.USER_EXCEPTION, "USER_EXCEPTION", reply)
    expect(reply.exception_type.endswith("Failure"), "exception_type ...Failure", reply.exception_type)
    if "Failure" in types:
        failure = types["Failure"].FromString(reply.payload)
        expect(failure.reason == "on purpose" and failure.code == 7, "the exception's fields", failure)


@check("9", "the server applies the deadline: DEADLINE_EXCEEDED, and other calls go on")
def deadline_exceeded(s):
    conn = s.open()
    start = time.monotonic()
    reply = s.call(conn, s.diag, "sleep", s.diag_request("sleep", ms=3000), deadline_ms=300)
    took = time.monotonic() - start
    expect(reply.status == pl.DEADLINE_EXCEEDED, "DEADLINE_EXCEEDED", reply)
    expect(took < 2.9, "answered before the provider's 3000 ms sleep ended", "%.2f s" % took)
    reply = s.call(conn, s.diag, "echo", s.diag_request("echo", text="after"), call_id=2)
    expect(reply.status == pl.OK, "the next call OK", reply)


@check("9", "a deadline_ms above the server's maximum is refused BAD_ARGUMENTS naming max_deadline_ms, not truncated")
def deadline_maximum(s):
    conn = s.open()
    reply = s.call(conn, s.diag, "echo", s.diag_request("echo", text="x"), deadline_ms=(1 << 32) + 5)
    expect(reply.status == pl.BAD_ARGUMENTS and "max_deadline_ms" in reply.message,
           "BAD_ARGUMENTS naming max_deadline_ms for 2^32 + 5 ms", reply)


@check("9", "a call_id pending on the connection is refused BAD_ARGUMENTS; the first call goes on")
def duplicate_call_id(s):
    conn = s.open()
    frame = pl.Frame()
    frame.request.call_id, frame.request.service, frame.request.operation = 7, s.diag, "sleep"
    frame.request.payload, frame.request.deadline_ms = s.diag_request("sleep", ms=1000), 10000
    conn.send(frame)
    frame.request.operation, frame.request.payload = "echo", s.diag_request("echo", text="dup")
    conn.send(frame)
    first = conn.expect("reply")
    expect(first is not None and first.reply.call_id == 7 and first.reply.status == pl.BAD_ARGUMENTS,
           "first a Reply BAD_ARGUMENTS for the duplicate", first)
    second = conn.expect("reply")
    expect(second is not None and second.reply.call_id == 7 and second.reply.status == pl.OK,
           "then the sleep's own Reply OK", second)


@check("9", "a oneway gets no Reply, not even for an unknown service")
def oneway_no_reply(s):
    conn = s.open()
    s.call(conn, "conformance.nothing-" + s.unique, "x", call_id=5, oneway=True)
    s.call(conn, s.diag, "echo", s.diag_request("echo", text="x"), call_id=6, oneway=True)
    reply = s.call(conn, s.diag, "echo", s.diag_request("echo", text="y"), call_id=8)
    expect(reply.call_id == 8, "only the Reply of call 8", reply)
    expect(conn.expect("reply", timeout=0.5) is None, "no Reply for the oneways")


@check("2", "pending calls per connection are bounded: RESOURCE_EXHAUSTED naming max_pending_calls_per_session")
def pending_calls_bounded(s):
    limit = s.limits["max_pending_calls_per_session"]
    # A provider of the suite's own that holds every call (answering only the server's Pings).
    name = "conformance.hold-" + s.unique
    sink = s.open("sam", name="conformance-sink", hello_role=pl.SAM)
    reply = s.register(sink, name, "conformance.Hold")
    expect(reply.status == pl.OK, "Register the holding service: OK", reply)
    conn = s.open()
    conn.send_all(pl.Frame(request=pl.Request(call_id=i + 1, service=name, operation="hold", deadline_ms=60000))
                  for i in range(limit + 1))
    refused = None
    deadline = time.monotonic() + 30
    while refused is None and time.monotonic() < deadline:
        sink.recv(0.05)
        refused = conn.expect("reply", timeout=0.2)
    expect(refused is not None and refused.reply.call_id == limit + 1 and
           refused.reply.status == pl.RESOURCE_EXHAUSTED and "max_pending_calls_per_session" in refused.reply.message,
           "call %d refused RESOURCE_EXHAUSTED naming max_pending_calls_per_session" % (limit + 1), refused)


# ---- 7. Chunking --------------------------------------------------------------------------------

def fnv1a64(data):
    h = 0xcbf29ce484222325
    for b in data:
        h ^= b
        h = (h * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


@check("7", "a request larger than chunk_bytes sent as Chunks is reassembled; a large reply arrives chunked and whole")
def chunking(s):
    conn = s.open()
    types = s.diag_types()
    data = bytes((i * 7) % 256 for i in range(3 * conn.chunk_bytes + 123))
    reply = s.call(conn, s.diag, "checksum", s.diag_request("checksum", data=data))
    expect(reply.status == pl.OK, "checksum OK", reply)
    expect(types["checksum"][1].FromString(reply.payload).result == fnv1a64(data), "the checksum of what was sent")
    size = 5 * conn.chunk_bytes
    reply = s.call(conn, s.diag, "blob", s.diag_request("blob", size=size), call_id=2)
    expect(reply.status == pl.OK, "blob OK", reply)
    blob = types["blob"][1].FromString(reply.payload).result
    expect(len(blob) == size and all(blob[i] == i % 251 for i in range(0, size, 997)), "the blob, whole")


@check("1", "a frame larger than chunk_bytes is a protocol error: Goodbye PAYLOAD_TOO_LARGE, close")
def oversized_frame(s):
    conn = s.open()
    size = conn.welcome.chunk_bytes + 1
    conn.send_raw(size.to_bytes(4, "big") + b"\0" * min(size, 1024))
    expect_goodbye(conn, pl.PAYLOAD_TOO_LARGE)


@check("7", "a chunk of an unknown message must start at offset 0: otherwise Goodbye BAD_ARGUMENTS")
def chunk_offset(s):
    conn = s.open()
    frame = pl.Frame()
    frame.chunk.message_id, frame.chunk.total_bytes, frame.chunk.offset = 9, 100, 10
    frame.chunk.data = b"x" * 10
    conn.send(frame)
    expect_goodbye(conn, pl.BAD_ARGUMENTS)


# ---- 5, 11. Events ------------------------------------------------------------------------------

def subscribe(conn, sid, pattern, resume_after=0):
    frame = pl.Frame()
    frame.subscribe.subscription_id, frame.subscribe.pattern = sid, pattern
    frame.subscribe.resume_after_seq = resume_after
    conn.send(frame)
    ack = conn.expect("subscribe_ack", match=lambda a: a.subscription_id == sid)
    expect(ack is not None, "a SubscribeAck for %d" % sid)
    return ack.subscribe_ack


def publish(conn, pid, topic, payload=b"", wait=True):
    frame = pl.Frame()
    frame.publish.publish_id, frame.publish.topic, frame.publish.payload = pid, topic, payload
    conn.send(frame)
    if not wait:
        return None
    ack = conn.expect("publish_ack", match=lambda a: a.publish_id == pid)
    expect(ack is not None, "a PublishAck for %d" % pid)
    return ack.publish_ack


@check("11", "events are acknowledged with increasing seqs and delivered in seq order; a resent publish_id keeps its seq")
def events_in_order(s):
    topic = "conformance/order/" + s.unique
    sub = s.open()
    ack = subscribe(sub, 1, "conformance/order/#")
    expect(ack.status == pl.OK, "SubscribeAck OK", ack)
    pub = s.open()
    seqs = [publish(pub, i, topic, str(i).encode()).seq for i in range(1, 6)]
    expect(seqs == sorted(seqs) and len(set(seqs)) == 5 and seqs[0] > ack.last_seq, "increasing seqs", seqs)
    again = publish(pub, 3, topic, b"resent")
    expect(again.status == pl.OK and again.seq == seqs[2], "the resent id 3 acknowledged with its seq", again)
    got = []
    while len(got) < 5:
        event = sub.expect("event", timeout=5)
        expect(event is not None, "5 events", got)
        got.append(event.event)
    expect([e.seq for e in got] == seqs and [e.payload for e in got] == [str(i).encode() for i in range(1, 6)],
           "the 5 events in seq order", [e.seq for e in got])
    expect(sub.expect("event", timeout=0.5) is None, "the resent publish not delivered again")


@check("11", "publish_id 0 is refused BAD_ARGUMENTS; so is a topic with a wildcard")
def publish_refusals(s):
    conn = s.open()
    ack = publish(conn, 0, "conformance/zero")
    expect(ack.status == pl.BAD_ARGUMENTS, "publish_id 0: BAD_ARGUMENTS", ack)
    ack = publish(conn, 1, "conformance/*")
    expect(ack.status == pl.BAD_ARGUMENTS and ack.seq == 0, "a wildcard topic: BAD_ARGUMENTS, seq 0", ack)


@check("11", "resume_after_seq replays the retained events after it, then live ones")
def resume(s):
    topic = "conformance/resume/" + s.unique
    pub = s.open()
    seqs = [publish(pub, i, topic, str(i).encode()).seq for i in range(1, 4)]
    sub = s.open()
    ack = subscribe(sub, 1, topic, resume_after=seqs[0])
    expect(ack.status == pl.OK and ack.last_seq >= seqs[2], "SubscribeAck OK", ack)
    got = [sub.expect("event", timeout=5) for _ in range(2)]
    expect(all(got) and [e.event.seq for e in got] == seqs[1:], "the events after seq %d replayed" % seqs[0], got)


@check("5", "a subscription id used twice on a session is ALREADY_EXISTS; an invalid pattern BAD_ARGUMENTS")
def subscribe_refusals(s):
    conn = s.open()
    expect(subscribe(conn, 1, "conformance/a").status == pl.OK, "the first OK")
    expect(subscribe(conn, 1, "conformance/b").status == pl.ALREADY_EXISTS, "the same id: ALREADY_EXISTS")
    expect(subscribe(conn, 2, "conformance/#/b").status == pl.BAD_ARGUMENTS, "'#' not last: BAD_ARGUMENTS")


@check("5", "Unsubscribe has no acknowledgement: events stop, an unknown id is ignored and the session goes on")
def unsubscribe_unacknowledged(s):
    topic = "conformance/unsubscribe/" + s.unique
    conn = s.open()
    expect(subscribe(conn, 1, topic).status == pl.OK, "SubscribeAck OK")
    conn.send_all([pl.Frame(unsubscribe=pl.Unsubscribe(subscription_id=1)),
                   pl.Frame(unsubscribe=pl.Unsubscribe(subscription_id=99))])
    ack = publish(conn, 1, topic)
    expect(ack.status == pl.OK, "the publish after Unsubscribe acknowledged", ack)
    answer = conn.recv(1.0)
    expect(answer is None, "nothing else: no acknowledgement, no event", answer)
    expect(subscribe(conn, 1, topic).status == pl.OK, "the id free again for a new subscription")


@check("2", "what a peer sent is quoted, not echoed whole, in an error (a 60,000-byte context key)")
def errors_quote_input(s):
    conn = s.open()
    key = "k" * 60000
    reply = s.call(conn, "camus.context", "Get", cm.ContextGetRequest(key=key).SerializeToString())
    expect(reply.status in (pl.NOT_FOUND, pl.BAD_ARGUMENTS), "NOT_FOUND or BAD_ARGUMENTS", reply.status)
    expect(len(reply.message) < 1000, "a message under 1000 bytes", len(reply.message))


@check("2", "topics and patterns over max_topic_bytes / max_topic_levels are refused BAD_ARGUMENTS naming the limit")
def topic_limits(s):
    conn = s.open()
    too_long = "w" * (s.limits["max_topic_bytes"] + 1)
    ack = subscribe(conn, 1, too_long)
    expect(ack.status == pl.BAD_ARGUMENTS and "max_topic_bytes" in ack.message, "pattern: max_topic_bytes", ack)
    expect(len(ack.message) < 1000, "the refusal does not quote the whole pattern", len(ack.message))
    too_deep = deep_topic(s.limits["max_topic_levels"] + 1)
    ack = subscribe(conn, 2, too_deep)
    expect(ack.status == pl.BAD_ARGUMENTS and "max_topic_levels" in ack.message, "pattern: max_topic_levels", ack)
    ack = publish(conn, 1, too_deep)
    expect(ack.status == pl.BAD_ARGUMENTS and "max_topic_levels" in ack.message, "topic: max_topic_levels", ack)
    ack = publish(conn, 2, too_long)
    expect(ack.status == pl.BAD_ARGUMENTS and "max_topic_bytes" in ack.message, "topic: max_topic_bytes", ack)


@check("2", "subscriptions per session are bounded: RESOURCE_EXHAUSTED naming max_subscriptions_per_session")
def subscription_limit(s):
    limit = s.limits["max_subscriptions_per_session"]
    conn = s.open()
    conn.send_all(pl.Frame(subscribe=pl.Subscribe(subscription_id=i + 1, pattern="conformance/limit/%d" % i))
                  for i in range(limit + 1))
    acks = {}
    while len(acks) < limit + 1:
        ack = conn.expect("subscribe_ack", timeout=20)
        expect(ack is not None, "%d SubscribeAcks" % (limit + 1), len(acks))
        acks[ack.subscribe_ack.subscription_id] = ack.subscribe_ack
    ok = sum(1 for a in acks.values() if a.status == pl.OK)
    expect(ok == limit, "%d accepted" % limit, ok)
    # The one refused says which limit: the subscriptions a session may hold, or (when the bus is
    # behind) the operations a session may have queued.
    refused = [a for a in acks.values() if a.status != pl.OK]
    expect(len(refused) == 1 and refused[0].status == pl.RESOURCE_EXHAUSTED and
           ("max_subscriptions_per_session" in refused[0].message or "event_queue" in refused[0].message),
           "one RESOURCE_EXHAUSTED naming max_subscriptions_per_session (or the bus queue)", refused)


@check("12", "the diagnostic notify event: payload is the serialized notify request, content_type its name, source the provider's identity")
def notify_event(s):
    types = s.diag_types()
    conn = s.open()
    listed = s.call(conn, "camus.registry", "List", cm.ListRequest(pattern=s.diag).SerializeToString())
    owners = [x.owner for x in cm.ListReply.FromString(listed.payload).services if x.name == s.diag]
    expect(owners, "%s listed" % s.diag)
    topic = "conformance/notify/" + s.unique
    subscribe(conn, 1, topic)
    s.call(conn, s.diag, "notify", s.diag_request("notify", topic=topic, text="hello"), call_id=2, oneway=True)
    event = conn.expect("event")
    expect(event is not None, "the notify event")
    request_type = types["notify"][0]
    expect(event.event.content_type == request_type.DESCRIPTOR.full_name, "content_type %s" %
           request_type.DESCRIPTOR.full_name, event.event.content_type)
    body = request_type.FromString(event.event.payload)
    expect(body.topic == topic and body.text == "hello", "payload {topic, text}", body)
    expect(event.event.source == owners[0], "source = the provider's identity %r" % owners[0], event.event.source)


@check("12", "the built-in services are listed, owned by camus-server")
def builtins_listed(s):
    conn = s.open()
    reply = s.call(conn, "camus.registry", "List", cm.ListRequest(pattern="camus.*").SerializeToString())
    expect(reply.status == pl.OK, "List OK", reply)
    services = {x.name: x.owner for x in cm.ListReply.FromString(reply.payload).services}
    for name in ("camus.registry", "camus.context", "camus.tasks"):
        expect(services.get(name) == "camus-server", "%s owned by camus-server" % name, services)


def run(suite, only=None, out=print):
    failed = passed = skipped = 0
    for section, text, fn in CHECKS:
        if only and not re.search(only, fn.__name__):
            continue
        start = time.monotonic()
        try:
            fn(suite)
            verdict, why = "PASS", ""
            passed += 1
        except Skip as e:
            verdict, why = "SKIP", str(e)
            skipped += 1
        except Fail as e:
            verdict, why = "FAIL", str(e)
            failed += 1
        except (Closed, OSError, ValueError) as e:
            verdict, why = "FAIL", "%s: %s" % (type(e).__name__, e)
            failed += 1
        finally:
            suite.close_all()
        took = time.monotonic() - start
        out("%-4s §%-4s %-34s %5.2fs  %s%s" % (verdict, section, fn.__name__, took, text, (" -- " + why) if why else ""))
    out("%d passed, %d failed, %d skipped" % (passed, failed, skipped))
    return failed == 0
