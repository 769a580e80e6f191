#!/usr/bin/python3
"""Integration test of the Python SDK (python/urslink) and its example (examples/python), against a
real urs-camus-server with named credentials, a urs-sam hosting the C++ diagnostic agent, and the
example's Python agent serving Demo.Thermostat:

  - the Python agent called with `urs call` (the C++ CLI encodes JSON from the registered description)
    and with the example's Python client;
  - a Python agent serving URS.Diagnostic from the server's description, answering `urs call` as
    the C++ agent does;
  - the Python client calling the C++ diagnostic agent: results, chunked payloads both ways,
    declared exceptions, deadlines, oneways and their events, errors, the registry, context, tasks;
  - an event of a type with no interface (RTC.TimedLong, urslink.Types) published and read back;
  - an RT consumer (`urs rtc call`, CORBA) calling the Python agent through urs-bridge;
  - credentials: a wrong token, roles;
  - reconnection: the server restarts on the same port; the agent's registration and a client's
    subscription are restored; calls made while disconnected wait in the bounded queue.

  run_sdk.py --server-bin B --sam-bin B --cli-bin B [--bridge-bin B] [--keep] [--only REGEX]
Prints PASS/FAIL per check; exit status 1 if one failed, 2 if the space did not start."""
import argparse
import asyncio
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
EXAMPLE = os.path.join(ROOT, "examples", "python")
sys.path.insert(0, os.path.join(ROOT, "python"))
sys.path.insert(0, os.path.join(ROOT, "tests", "conformance"))
import urslink  # noqa: E402
from run_camus import wait_for  # noqa: E402  (polls a condition every 50 ms)
from urslink import planet_pb2 as pl  # noqa: E402

PY = "/usr/bin/python3"


class Failed(Exception):
    pass


def cli(argv):
    """Runs the urs CLI with its stderr after its stdout, less the "trace <id>" line `urs call` and
    `urs rtc call` print there (docs/operations.md, "Following one call"), so a reply stays JSON."""
    run = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
    run.stdout = re.sub(r"^trace [0-9a-f]{32}\n", "", run.stdout, flags=re.M)
    return run


def expect(condition, what, seen=None):
    if not condition:
        raise Failed(what + ("" if seen is None else "; seen: %r" % (seen,)))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Space:
    """urs-camus-server, urs-sam (diag, or the agents of `sam_agents`) and the example's Python
    agent, in a temporary folder (omniNames and urs-bridge too, for the RT check)."""

    def __init__(self, args, name="sdk", sam_config="agents:\n  - name: diag\n    type: diagnostic\n    deadline_ms: 5000\n"):
        for binary in ("server_bin", "sam_bin", "cli_bin", "bridge_bin"):
            if getattr(args, binary, ""):
                setattr(args, binary, os.path.abspath(getattr(args, binary)))
        self.args = args
        self.name = name
        self.work = tempfile.mkdtemp(prefix="urslink-%s-" % name)
        self.port = free_port()
        self.server = "127.0.0.1:%d" % self.port
        self.tokens = {}
        self.processes = {}
        self.logs = []
        for role in ("client", "sam", "operator"):
            self.tokens[role] = os.path.join(self.work, role + ".token")
            with open(self.tokens[role], "w") as f:
                f.write("%s-%d-%s\n" % (role, os.getpid(), os.urandom(8).hex()))
        with open(os.path.join(self.work, "credentials.yaml"), "w") as f:
            f.write("credentials:\n")
            for role in self.tokens:
                f.write("  - name: sdk-%s\n    role: %s\n    token_file: %s.token\n" % (role, role, role))
        with open(os.path.join(self.work, "sam.yaml"), "w") as f:
            f.write(sam_config)

    def path(self, name):
        return os.path.join(self.work, name)

    def start(self, name, argv):
        log = open(self.path(name + ".log"), "a")
        self.logs.append(log)
        self.processes[name] = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, cwd=self.work)

    def log(self, name):
        with open(self.path(name + ".log")) as f:
            return f.read()

    def start_server(self):
        self.start("server", [self.args.server_bin, "--space", self.name, "--listen", self.server,
                              "--credentials", self.path("credentials.yaml"), "--log-level", "info"])

    def stop(self, name):
        p = self.processes.pop(name, None)
        if p is None:
            return
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()

    def up(self, agent=True, sam_service="diag"):
        self.start_server()
        if not wait_for(lambda: "listening on" in self.log("server"), 20):
            return "the server did not start"
        self.start("sam", [self.args.sam_bin, "--space", self.name, "--server", self.server, "--config",
                           self.path("sam.yaml"), "--token-file", self.tokens["sam"], "--log-level", "info"])
        sam_registered = lambda: re.search(r"^%s " % re.escape(sam_service), self.urs("ls").stdout, re.M)  # noqa: E731
        if not agent:
            return None if wait_for(sam_registered, 30) else "the SAM did not register " + sam_service
        self.start("agent", [PY, os.path.join(EXAMPLE, "thermostat_agent.py"), "--server", self.server,
                             "--token-file", self.tokens["sam"], "--room", "kitchen"])
        if not wait_for(lambda: "serving thermo" in self.log("agent") and self.urs_ok("ls"), 30):
            return "the Python agent did not register thermo"
        if not wait_for(sam_registered, 30):
            return "the SAM did not register " + sam_service
        return None

    def urs(self, *argv, token="client"):
        return cli([self.args.cli_bin, "--server", self.server, "--token-file", self.tokens[token]] + list(argv))

    def urs_ok(self, *argv):
        run = self.urs(*argv)
        return run.returncode == 0 and "thermo" in run.stdout

    def down(self):
        for name in list(self.processes)[::-1]:
            self.stop(name)
        for log in self.logs:
            log.close()

    def clean_up(self, failed, keep, logs=("server", "sam", "agent")):
        """After down(): prints the tail of each log when something failed, and keeps the work
        folder then (or with `keep`), else removes it."""
        if failed:
            for name in logs:
                if os.path.exists(self.path(name + ".log")):
                    print("---- %s %s log (tail)" % (self.name, name))
                    print(self.log(name)[-3000:])
        if keep or failed:
            print("work folder:", self.work)
        else:
            shutil.rmtree(self.work, ignore_errors=True)


# ---- checks ------------------------------------------------------------------------------------

def check_urs_call(space):
    """`urs call` (C++ CLI) calls the Python agent: JSON in and out, attributes, declared exceptions."""
    run = space.urs("call", "thermo", "setTarget", '{"celsius": 22.5}')
    expect(run.returncode == 0, "urs call thermo setTarget succeeds", run.stdout)
    reply = json.loads(run.stdout)
    expect(reply["result"]["target"] == 22.5, "the reply carries the new target", reply)
    run = space.urs("call", "thermo", "_get_room")
    expect(run.returncode == 0 and json.loads(run.stdout)["result"] == "kitchen", "the attribute room", run.stdout)
    run = space.urs("call", "thermo", "setTarget", '{"celsius": 99}')
    expect(run.returncode != 0, "an out-of-range target fails", run.stdout)
    expect("Demo.OutOfRange" in run.stdout and "USER_EXCEPTION" in run.stdout,
           "urs call shows USER_EXCEPTION Demo.OutOfRange", run.stdout)
    run = space.urs("call", "thermo", "warp", "{}")
    expect(run.returncode != 0 and "warp" in run.stdout, "an unknown operation is refused", run.stdout)
    run = space.urs("describe", "thermo")
    expect(run.returncode == 0 and "setTarget" in run.stdout and "nudge" in run.stdout, "urs describe thermo",
           run.stdout)


def check_example_client(space):
    """The example's Python client calls the Python agent."""
    run = subprocess.run([PY, os.path.join(EXAMPLE, "thermostat_client.py"), "--server", space.server,
                          "--token-file", space.tokens["client"]], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, timeout=60)
    expect(run.returncode == 0, "thermostat_client.py exits 0", run.stdout)
    for line in ("room: kitchen", "setTarget(21.5): 21.5", "event on thermostat/thermo/target from sdk-sam: Demo.Reading",
                 "setTarget(99) raised Demo.OutOfRange {'requested': 99.0, 'min': 5.0, 'max': 30.0}",
                 "after nudge: 22.0"):
        expect(line in run.stdout, "the client prints %r" % line, run.stdout)


async def check_diagnostic(space):
    """The Python client calls the C++ diagnostic agent served by urs-sam."""
    async with urslink.Client(space.server, token_file=space.tokens["client"], peer_name="sdk-test") as client:
        expect(client.identity == "sdk-client" and client.role == pl.CLIENT and client.space == "sdk",
               "Welcome: identity, role, space", client.welcome)
        expect(client.welcome.session_secret == "", "the session secret is not exposed")
        names = [s.name for s in await client.list_services()]
        expect("diag" in names and "thermo" in names, "list_services() has diag and thermo", names)
        diag = await client.proxy("diag")
        expect(diag.interface.name == "URS.Diagnostic", "described as URS.Diagnostic", diag.interface)
        expect((await diag.echo(text="héllo")).result == "héllo", "echo")
        expect((await diag.add(a=2, b=0.5)).result == 2.5, "add")
        blob = (await diag.blob(size=300000)).result       # chunked reply
        expect(len(blob) == 300000 and blob[:3] == bytes([0, 1, 2]) and blob[251] == 0, "blob of 300000 bytes")
        data = os.urandom(200000)                          # chunked request
        fnv = 0xcbf29ce484222325
        for byte in data:
            fnv = ((fnv ^ byte) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
        expect((await diag.checksum(data=data)).result == fnv, "checksum of 200000 bytes")
        try:
            await diag.fail(reason="broken", code=7)
            raise Failed("fail() did not raise")
        except urslink.UserException as error:
            expect(error.type_name == "URS.Failure" and error.code == "USER_EXCEPTION", "fail raises URS.Failure", error)
            expect(error.fields == {"reason": "broken", "code": 7}, "the exception's fields", error.fields)
            expect(error.value.reason == "broken", "the exception's decoded value", error.value)
        try:
            await diag.sleep(ms=3000, deadline_ms=300)
            raise Failed("sleep(3000) with deadline 300 ms returned")
        except urslink.PlanetError as error:
            expect(error.code == "DEADLINE_EXCEEDED", "a call past its deadline fails DEADLINE_EXCEEDED", error)
        await diag.sleep(ms=50)                             # no deadline: the service's 5 s applies
        try:
            await client.call("nobody", "op")
            raise Failed("a call to an unknown service returned")
        except urslink.PlanetError as error:
            expect(error.code == "UNKNOWN_SERVICE", "UNKNOWN_SERVICE", error)
        try:
            await client.call("diag", "echo", b"\xff\xff\xff")
            raise Failed("a malformed payload was accepted")
        except urslink.PlanetError as error:
            expect(error.code == "BAD_ARGUMENTS", "a malformed payload is BAD_ARGUMENTS", error)

        events = await client.subscribe("sdk/notify/#")
        await diag.notify(topic="sdk/notify/one", text="ping")   # oneway
        event = await events.get(timeout=10)
        request = diag.interface.message_class(event.content_type).FromString(event.payload)
        expect(event.topic == "sdk/notify/one" and request.text == "ping" and event.source == "sdk-sam",
               "the oneway notify publishes its event", event)
        seen = []
        done = asyncio.Event()

        async def on_event(e):
            seen.append(e.payload)
            if len(seen) == 3:
                done.set()
        await client.subscribe("sdk/mine/*", on_event)
        for i in range(3):
            seq = await client.publish("sdk/mine/x", b"%d" % i, "text/plain")
            expect(seq > 0, "publish returns the seq", seq)
        await asyncio.wait_for(done.wait(), 10)
        expect(seen == [b"0", b"1", b"2"], "a callback subscription gets the events in order", seen)
        try:
            await client.publish("registry/fake", b"x")
            raise Failed("a publish on a server topic was accepted")
        except urslink.PlanetError as error:
            expect(error.code == "PERMISSION_DENIED", "publish on registry/ is PERMISSION_DENIED", error)

        try:
            await client.context_set("sdk/x", 1)
            raise Failed("a client set a context entry")
        except urslink.PlanetError as error:
            expect(error.code == "PERMISSION_DENIED", "context Set needs role operator", error)
        tasks = await client.task_list()
        expect(tasks is not None, "task_list()")


async def check_types_event(space):
    """An event of a type from an IDL file without an interface (OpenRTM-aist's RTC.TimedLong),
    published and read back with urslink.Types."""
    rtc = urslink.Types.from_idl(os.path.join(ROOT, "idl", "rtc", "BasicDataType.idl"))
    TimedLong = rtc.message_class("RTC.TimedLong")
    async with urslink.Client(space.server, token_file=space.tokens["client"], peer_name="sdk-types") as client:
        counts = await client.subscribe("sdk/rt/count")
        await client.publish("sdk/rt/count", TimedLong(tm={"sec": 12, "nsec": 345}, data=-7))
        event = await counts.get(timeout=10)
        value = rtc.decode(event)
        expect(event.content_type == "RTC.TimedLong" and (value.tm.sec, value.tm.nsec, value.data) == (12, 345, -7),
               "an RTC.TimedLong event published and decoded with urslink.Types", (event, value))


async def check_transparency(space):
    """A Python agent serving URS.Diagnostic (described by the server, no IDL file) answers `urs call`
    as the C++ diagnostic agent does: same output and exit status, exceptions included."""
    async with urslink.Client(space.server, token_file=space.tokens["sam"], role="sam") as client:
        interface = await client.describe(interface="URS.Diagnostic")

        class PyDiag(urslink.Agent):
            def echo(self, request):
                return request.text

            def add(self, request):
                return request.a + request.b

            def fail(self, request):
                raise interface.exception("Failure", "Failure: " + request.reason, reason=request.reason,
                                          code=request.code)

        await client.serve("pydiag", PyDiag(interface), deadline_ms=5000)
        loop = asyncio.get_running_loop()
        for argv in (("echo", '{"text": "héllo"}'), ("add", '{"a": 1.5, "b": 2}'),
                     ("fail", '{"reason": "broken", "code": 7}'), ("fail", '{"reason": "x", "code": "y"}'),
                     ("checksum", "{}")):
            native, python = [await loop.run_in_executor(None, lambda s=service: space.urs("call", s, *argv))
                              for service in ("diag", "pydiag")]
            if argv[0] == "checksum":   # not implemented by PyDiag
                expect(python.returncode != 0 and "UNKNOWN_OPERATION" in python.stdout,
                       "an operation the agent lacks is UNKNOWN_OPERATION", python.stdout)
                continue
            expect((native.returncode, native.stdout) == (python.returncode, python.stdout.replace("pydiag", "diag")),
                   "urs call %s: the Python agent answers as the C++ one" % " ".join(argv),
                   (native.returncode, native.stdout, python.returncode, python.stdout))


async def check_context(space):
    """Context get/set/ls/delete and tasks with an operator credential."""
    async with urslink.Client(space.server, token_file=space.tokens["operator"], role="operator") as op:
        entry = await op.context_set("sdk/room", {"name": "kitchen", "size": 12})
        expect(entry.source == "sdk-operator" and entry.version >= 1, "context_set returns the entry", entry)
        got = await op.context_get("sdk/room")
        expect(urslink.value_of(got) == {"name": "kitchen", "size": 12}, "context_get", urslink.value_of(got))
        keys = [e.key for e in await op.context_ls("sdk/*")]
        expect(keys == ["sdk/room"], "context_ls", keys)
        # A task whose step calls the Python agent (the server encodes its args with the registered description).
        definition = await op.task_define("sdk-warm", "steps:\n  - call: {service: thermo, operation: setTarget, "
                                          "args: {celsius: 23.5}, deadline_ms: 5000}\n")
        expect(definition.name == "sdk-warm", "task_define", definition)
        run = await op.task_run("sdk-warm")
        for _ in range(100):
            run = await op.task_status(run.run_id)
            if run.state != "running":
                break
            await asyncio.sleep(0.05)
        expect(run.state == "succeeded", "the task's call to the Python agent succeeded", run)
        thermo = await op.proxy("thermo")
        expect((await thermo.read()).result.target == 23.5, "the task set the Python agent's target")
        expect("sdk-warm" in [t.name for t in (await op.task_list()).tasks], "task_list has the task")
        await op.context_delete("sdk/room")
        try:
            await op.context_get("sdk/room")
            raise Failed("a deleted entry was found")
        except urslink.PlanetError as error:
            expect(error.code == "NOT_FOUND", "a deleted key is NOT_FOUND", error)


async def check_credentials(space):
    """A wrong token is refused (start() says why); a client role cannot serve."""
    wrong = space.path("wrong.token")
    with open(wrong, "w") as f:
        f.write("not-a-token\n")
    client = urslink.Client(space.server, token_file=wrong, reconnect_min=0.2)
    try:
        await client.start(timeout=3)
        raise Failed("a wrong token was admitted")
    except urslink.PlanetError as error:
        expect(error.code == "UNAVAILABLE" and "refused: wrong token" in error.message, "refused: wrong token", error)
    finally:
        await client.close()
    interface = urslink.Interface.from_idl(os.path.join(EXAMPLE, "Thermostat.idl"))
    async with urslink.Client(space.server, token_file=space.tokens["client"]) as client:
        try:
            await client.serve("thermo2", urslink.Agent(interface))
            raise Failed("a client role registered a service")
        except urslink.PlanetError as error:
            expect(error.code == "PERMISSION_DENIED", "serve() needs role sam", error)


async def check_queue(space):
    """Without a server: calls wait in the bounded queue, then fail UNAVAILABLE naming why."""
    client = urslink.Client("127.0.0.1:%d" % free_port(), token="x", queue_timeout=0.5, max_queued=2)
    await client.start(wait=False)
    try:
        waiting = [asyncio.ensure_future(client.call("diag", "echo")) for _ in range(2)]
        await asyncio.sleep(0)
        try:
            await client.call("diag", "echo")
            raise Failed("a third call was queued")
        except urslink.PlanetError as error:
            expect(error.code == "UNAVAILABLE" and "queue of 2 is full" in error.message, "the queue is bounded", error)
        for future in waiting:
            try:
                await future
                raise Failed("a queued call succeeded without a server")
            except urslink.PlanetError as error:
                expect(error.code == "UNAVAILABLE" and "not sent" in error.message, "a queued call times out", error)
        expect("cannot connect" in client.last_error, "last_error says why", client.last_error)
    finally:
        await client.close()


async def check_reconnect(space):
    """The server restarts on the same port: registrations and subscriptions come back."""
    async with urslink.Client(space.server, token_file=space.tokens["client"], peer_name="sdk-reconnect") as client:
        events = await client.subscribe("sdk/after/#")
        registrations = space.log("server").count("service thermo (")
        space.stop("server")
        await asyncio.sleep(0.3)
        expect(not client.connected, "the client saw the server go")
        # waits in the queue (a built-in service: the SAM registers diag again only after its own reconnect)
        queued = asyncio.ensure_future(client.list_services("thermo*"))
        await asyncio.sleep(0.2)
        expect(not queued.done(), "the call waits for a connection")
        space.start_server()
        await client.wait_connected(20)
        answer = await asyncio.wait_for(queued, 20)
        expect(isinstance(answer, list), "a call queued while disconnected is sent after the reconnect", answer)
        ok = await asyncio.get_running_loop().run_in_executor(
            None, lambda: wait_for(lambda: space.log("server").count("service thermo (") > registrations, 20))
        expect(ok, "the Python agent registered thermo again")
        run = space.urs("call", "thermo", "read")
        expect(run.returncode == 0 and "target" in run.stdout, "urs call reaches the agent after the restart", run.stdout)
        async with urslink.Client(space.server, token_file=space.tokens["client"]) as other:
            await other.publish("sdk/after/restart", b"back")
        event = await events.get(timeout=10)
        expect(event.payload == b"back", "the subscription was restored", event)


class CuttableProxy:
    """A TCP relay to the server whose connections the test can cut, as a network failure would."""

    def __init__(self, target_port):
        self.target_port = target_port
        self.writers = []

    async def start(self):
        self.server = await asyncio.start_server(self.relay, "127.0.0.1", 0)
        self.address = "127.0.0.1:%d" % self.server.sockets[0].getsockname()[1]

    async def relay(self, reader, writer):
        upstream_reader, upstream_writer = await asyncio.open_connection("127.0.0.1", self.target_port)
        self.writers += [writer, upstream_writer]

        async def pipe(source, sink):
            try:
                while True:
                    data = await source.read(65536)
                    if not data:
                        break
                    sink.write(data)
            except (ConnectionError, OSError):
                pass
            finally:
                sink.close()
        await asyncio.gather(pipe(reader, upstream_writer), pipe(upstream_reader, writer))

    def cut(self):
        for writer in self.writers:
            writer.transport.abort()
        self.writers = []

    async def close(self):
        self.cut()
        self.server.close()


async def check_resume(space):
    """A cut connection: the session is resumed with its secret; the registration carries over and
    events published meanwhile are replayed to the subscription."""
    proxy = CuttableProxy(space.port)
    await proxy.start()
    interface = urslink.Interface.from_idl(os.path.join(EXAMPLE, "Thermostat.idl"))

    class Room(urslink.Agent):
        def _get_room(self, request):
            return "attic"
    try:
        async with urslink.Client(proxy.address, token_file=space.tokens["sam"], role="sam",
                                  peer_name="sdk-resume") as agent_client:
            await agent_client.serve("thermo-resume", Room(interface))
            events = await agent_client.subscribe("sdk/resume/#")
            async with urslink.Client(space.server, token_file=space.tokens["client"]) as caller:
                room = await caller.proxy("thermo-resume")
                expect((await room._get_room()).result == "attic", "the in-process agent answers")
                proxy.cut()
                for i in range(3):                  # published while the subscriber is cut off
                    await caller.publish("sdk/resume/x", b"%d" % i)
                for _ in range(200):
                    if agent_client.sessions >= 2 and agent_client.connected:
                        break
                    await asyncio.sleep(0.05)
                expect(agent_client.sessions >= 2 and agent_client.resumed, "the session was resumed",
                       (agent_client.sessions, agent_client.resumed, agent_client.last_error))
                got = [(await events.get(timeout=10)).payload for _ in range(3)]
                expect(got == [b"0", b"1", b"2"], "events published meanwhile are replayed in order", got)
                expect((await room._get_room(deadline_ms=5000)).result == "attic",
                       "the registration carried over the resumed session")
    finally:
        await proxy.close()


def check_rt_consumer(space):
    """An RT consumer calls the Python agent through urs-bridge: the bridge offers thermo as an RTC
    whose provider port has the interface described by the registry; `urs rtc call` (a CORBA
    consumer, dynamic invocation with the example's IDL) calls it."""
    if not space.args.bridge_bin or not shutil.which("omniNames"):
        raise Skip("no --bridge-bin or no omniNames")
    naming_port = free_port()
    naming = "127.0.0.1:%d" % naming_port
    os.makedirs(space.path("naming"), exist_ok=True)
    space.start("omniNames", ["omniNames", "-start", str(naming_port), "-datadir", space.path("naming"),
                              "-logdir", space.path("naming"), "-ORBendPoint", "giop:tcp:" + naming])
    with open(space.path("bridge.yaml"), "w") as f:
        f.write("name: bridge-sdk\ncamus_to_rt:\n  poll_ms: 200\n  services:\n"
                "    - {match: thermo, instance: \"camus_{service}\", deadline_ms: 5000}\n")
    space.start("bridge", [space.args.bridge_bin, "--space", "sdk", "--server", space.server, "--naming", naming,
                           "--host", "sdkhost", "--config", space.path("bridge.yaml"), "--token-file",
                           space.tokens["sam"], "--ready-file", space.path("bridge.ready"), "--log-level", "info"])
    port = "sdkhost.host_cxt/camus_thermo.rtc:thermostat"
    idl = os.path.join(EXAMPLE, "Thermostat.idl")

    def rtc(*argv):
        return cli([space.args.cli_bin, "rtc", "--naming", naming] + list(argv))
    expect(wait_for(lambda: rtc("call", port, "_get_room", "--idl", idl).returncode == 0, 40),
           "the bridge offers thermo to RT consumers", rtc("call", port, "_get_room", "--idl", idl).stdout)
    run = rtc("call", port, "setTarget", '{"celsius": 24.5}', "--idl", idl)
    expect(run.returncode == 0 and "24.5" in run.stdout, "an RT consumer sets the target through the bridge", run.stdout)
    run = rtc("call", port, "setTarget", '{"celsius": -40}', "--idl", idl)
    expect(run.returncode != 0 and "OutOfRange" in run.stdout and "-40" in run.stdout,
           "Demo.OutOfRange reaches the RT consumer as a CORBA user exception with its fields", run.stdout)
    space.stop("bridge")
    space.stop("omniNames")


class Skip(Exception):
    pass


CHECKS = [("urs_call_python_agent", check_urs_call), ("python_client_example", check_example_client),
          ("python_client_diagnostic", check_diagnostic), ("python_types_event", check_types_event),
          ("python_agent_as_cpp_agent", check_transparency),
          ("python_client_context", check_context),
          ("python_client_credentials", check_credentials), ("python_client_queue", check_queue),
          ("python_resume", check_resume), ("python_rt_consumer_via_bridge", check_rt_consumer),
          ("python_reconnect", check_reconnect)]


def run_checks(checks, subject, only=""):
    """Runs each (name, check) on `subject` (async ones bounded to 120 s), printing PASS, SKIP or
    FAIL and why; returns the number of failures."""
    failures = 0
    for name, check in checks:
        if only and not re.search(only, name):
            continue
        try:
            if asyncio.iscoroutinefunction(check):
                asyncio.run(asyncio.wait_for(check(subject), 120))
            else:
                check(subject)
            print("PASS", name, flush=True)
        except Skip as why:
            print("SKIP", name + ":", why, flush=True)
        except Failed as error:
            failures += 1
            print("FAIL", name + ":", error, flush=True)
        except Exception as error:
            failures += 1
            print("FAIL", name + ": raised %s: %s" % (type(error).__name__, error), flush=True)
    return failures


def run_suite(subject, checks, only, clean_up):
    """Brings `subject` up (its up() returns what went wrong, or None), runs the checks on it
    (run_checks) and takes it down, then calls clean_up(failures), failures -1 when set-up failed.
    Returns the exit status: 0 every check passed, 1 one failed, 2 set-up failed."""
    failures = 0
    try:
        problem = subject.up()
        if problem:
            print("SETUP FAILED:", problem)
            failures = -1
            return 2
        failures = run_checks(checks, subject, only)
        return 1 if failures else 0
    finally:
        subject.down()
        clean_up(failures)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--sam-bin", required=True)
    parser.add_argument("--cli-bin", required=True)
    parser.add_argument("--bridge-bin", default="")
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--only", default="")
    args = parser.parse_args()
    os.environ.setdefault("URS_OMNIIDL_BACKEND_DIR", os.path.join(ROOT, "idl", "omniidl_planet"))
    space = Space(args)
    return run_suite(space, CHECKS, args.only, lambda failures: space.clean_up(failures, args.keep))


if __name__ == "__main__":
    sys.exit(main())
