#!/usr/bin/python3
"""What each budget of urs-camus-server costs in memory, measured: a fresh server (and a urs-sam
hosting the diagnostic agent, for held calls) per budget, filled with N units over raw Planet
connections from several credentials; the cost of one unit is the growth of the server's resident
memory (VmRSS) divided by N; then the units are given back (the connections closed) and, after
the server's heap trim period (10 s), what is still resident is measured. Prints a Markdown table
(docs/operations.md, "Limits and what they cost").

  budget_cost.py --server-bin B --sam-bin B [--pythonpath DIRS] [--units N]

Needs python3-protobuf and the generated planet_pb2/camus_pb2 (the build's
services/lib/planet/urs_planet_proto/python). Loopback only; takes about a minute.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def rss_kib(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1


class Space:
    """A server (and optionally a SAM) with one credential per role and a few client credentials."""

    def __init__(self, args, extra, with_sam=False):
        self.work = tempfile.mkdtemp(prefix="budget-cost-")
        self.tokens = {}
        with open(os.path.join(self.work, "credentials.yaml"), "w") as f:
            f.write("credentials:\n")
            names = [("sam", "sam")] + [("client%d" % i, "client") for i in range(10)]
            for name, role in names:
                self.tokens[name] = "%s-%d-%s" % (name, os.getpid(), os.urandom(6).hex())
                with open(os.path.join(self.work, name + ".token"), "w") as t:
                    t.write(self.tokens[name] + "\n")
                f.write("  - name: %s\n    role: %s\n    token_file: %s.token\n" % (name, role, name))
        port_file = os.path.join(self.work, "port")
        self.server = subprocess.Popen(
            [args.server_bin, "--space", "cost", "--listen", "127.0.0.1:0", "--port-file", port_file,
             "--credentials", os.path.join(self.work, "credentials.yaml"), "--log-level", "warn",
             "--heartbeat-timeout-ms", "600000", "--max-connections-per-address", "100000", "--reserved-percent", "0"] + extra,
            stdout=subprocess.DEVNULL, stderr=open(os.path.join(self.work, "server.log"), "w"))
        deadline = time.monotonic() + 20
        while not os.path.exists(port_file):
            if time.monotonic() > deadline:
                raise SystemExit("the server did not start: " + open(os.path.join(self.work, "server.log")).read())
            time.sleep(0.05)
        self.port = int(open(port_file).read())
        self.sam = None
        if with_sam:
            with open(os.path.join(self.work, "sam.yaml"), "w") as f:
                f.write("workers: 1\nagents:\n  - name: diag\n    type: diagnostic\n    deadline_ms: 600000\n")
            self.sam = subprocess.Popen(
                [args.sam_bin, "--space", "cost", "--server", "127.0.0.1:%d" % self.port, "--config",
                 os.path.join(self.work, "sam.yaml"), "--token-file", os.path.join(self.work, "sam.token"),
                 "--log-level", "warn"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            conn = self.session("client0")
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:
                listed = call(conn, 1, "camus.registry", "List", cm.ListRequest(pattern="diag").SerializeToString())
                if any(s.name == "diag" for s in cm.ListReply.FromString(listed.payload).services):
                    break
                time.sleep(0.1)
            conn.close()

    def session(self, who):
        conn = Connection("127.0.0.1", self.port)
        answer = conn.hello(self.tokens[who], who, pl.CLIENT)
        if answer is None or answer.WhichOneof("body") != "welcome":
            raise SystemExit("no Welcome for %s: %s" % (who, answer))
        return conn

    def rss(self):
        time.sleep(0.3)  # what was sent is handled
        return rss_kib(self.server.pid)

    def stop(self):
        if self.sam is not None:
            self.sam.kill()  # its worker may be in a long diag.sleep
            self.sam.wait()
        self.server.terminate()
        self.server.wait()
        shutil.rmtree(self.work, ignore_errors=True)


def call(conn, call_id, service, operation, payload=b"", deadline_ms=0, wait=True):
    frame = pl.Frame()
    r = frame.request
    r.call_id, r.service, r.operation, r.payload, r.deadline_ms = call_id, service, operation, payload, deadline_ms
    conn.send(frame)
    if not wait:
        return None
    return conn.expect("reply", match=lambda x: x.call_id == call_id).reply


def per_unit(before, after, units):
    return (after - before) * 1024.0 / units


# The server returns freed heap pages every 10 s (urs-camus-server, kHeapTrimPeriod).
TRIM_WAIT_S = 11


def given_back(space, conns, before):
    """Closes `conns`; KiB still resident above `before` once the heap was trimmed."""
    for conn in conns:
        conn.close()
    time.sleep(TRIM_WAIT_S)
    return space.rss() - before


def sessions(args, n):
    space = Space(args, ["--max-sessions-per-credential", str(n)])
    try:
        before = space.rss()
        held = [space.session("client%d" % (i % 10)) for i in range(n)]
        return per_unit(before, space.rss(), n), given_back(space, held, before)
    finally:
        space.stop()


def resumable(args, n):
    space = Space(args, ["--max-resumable-sessions", str(n), "--max-resumable-sessions-per-credential", str(n)])
    try:
        first = space.session("client0")
        first.close()
        time.sleep(0.5)
        # The memory the connections themselves used is reused from one to the next: what grows
        # is the closed sessions kept.
        before = space.rss()
        for i in range(n):
            conn = space.session("client%d" % (i % 10))
            conn.close()
        return per_unit(before, space.rss(), n), None
    finally:
        space.stop()


def subscriptions(args, n, pattern_of):
    per_session = 1000
    space = Space(args, ["--max-subscriptions", str(n), "--max-subscriptions-per-credential", str(n),
                         "--max-subscriptions-per-session", str(per_session)])
    try:
        conns = [space.session("client%d" % (i % 10)) for i in range((n + per_session - 1) // per_session)]
        before = space.rss()
        for k, conn in enumerate(conns):
            ids = range(k * per_session, min(n, (k + 1) * per_session))
            conn.send_all(pl.Frame(subscribe=pl.Subscribe(subscription_id=i + 1, pattern=pattern_of(i))) for i in ids)
            for _ in ids:
                ack = conn.expect("subscribe_ack", timeout=30)
                if ack is None or ack.subscribe_ack.status != pl.OK:
                    raise SystemExit("subscription refused: %s" % ack)
        return per_unit(before, space.rss(), n), given_back(space, conns, before)
    finally:
        space.stop()


def pending_calls(args, n):
    per_session = 1000
    space = Space(args, ["--max-pending-calls", str(n), "--max-pending-calls-per-credential", str(n),
                         "--max-pending-calls-per-session", str(per_session)], with_sam=True)
    try:
        conns = [space.session("client%d" % (i % 10)) for i in range((n + per_session - 1) // per_session)]
        sleep = sleep_request(space)
        before = space.rss()
        for k, conn in enumerate(conns):
            for i in range(k * per_session, min(n, (k + 1) * per_session)):
                call(conn, i + 1, "diag", "sleep", sleep, deadline_ms=86400000, wait=False)
        time.sleep(1.0)
        return per_unit(before, space.rss(), n), given_back(space, conns, before)
    finally:
        space.stop()


def sleep_request(space):
    """URS.Diagnostic_sleep_Request{ms: 600000}, built from the registry's description."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    conn = space.session("client0")
    described = cm.DescribeReply.FromString(
        call(conn, 1, "camus.registry", "Describe", cm.DescribeRequest(service="diag").SerializeToString()).payload)
    conn.close()
    pool = descriptor_pool.DescriptorPool()
    for f in descriptor_pb2.FileDescriptorSet.FromString(described.descriptor_set).file:
        pool.Add(f)
    method = pool.FindServiceByName(described.interface).FindMethodByName("sleep")
    make = getattr(message_factory, "GetMessageClass", None) or message_factory.MessageFactory(pool).GetPrototype
    return make(method.input_type)(ms=600000).SerializeToString()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--sam-bin", required=True)
    parser.add_argument("--pythonpath", default="")
    parser.add_argument("--units", type=int, default=5000, help="units of each budget filled (default 5000)")
    args = parser.parse_args()
    sys.path[:0] = [p for p in args.pythonpath.split(":") if p] + [os.path.join(HERE, "..", "conformance")]
    global pl, cm, Connection
    import camus_pb2 as cm
    import planet_pb2 as pl
    from planet.wire import Connection

    n = args.units
    worst = lambda i: "w%05d%s" % (i, "y" * 10) + ("/" + "x" * 15) * 31  # 512 bytes, 32 levels
    typical = lambda i: "kr/robot%d/#" % i
    rows = [
        ("open session (idle, after its handshake)", sessions(args, min(n, 2000)), min(n, 2000)),
        ("closed session kept resumable", resumable(args, n), n),
        ("subscription, typical pattern (kr/robotN/#)", subscriptions(args, n, typical), n),
        ("subscription, largest pattern (512 bytes, 32 levels)", subscriptions(args, n, worst), n),
        ("pending call (diag.sleep held by the SAM, 24 h deadline)", pending_calls(args, n), n),
    ]
    print("| unit | bytes of server memory each (VmRSS growth / units) | units | KiB still resident 10 s after they were given back |")
    print("|---|---|---|---|")
    for name, (cost, left), units in rows:
        print("| %s | %s | %s | %s |" % (name, "{:,.0f}".format(cost), "{:,}".format(units),
                                         "—" if left is None else "{:,}".format(left)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
