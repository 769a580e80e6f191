#!/usr/bin/env python3
"""rtshell, OpenRTM-aist's command-line tools, as a real peer of URSLink's RT side.

rtshell-aist 4.2.10 on rtctree-aist 4.2.5 and omniORBpy 4.2.5 (the salome-omniorb wheel) are
installed from PyPI into a virtual environment under the build folder, reused by later runs.
rtctree ships its IDL compiled into its own package; the tools that import the top-level RTC
module (rtexit) get it compiled here with omniidl's Python back end, as OpenRTM-aist-Python would
install it. Then, against omniNames, urs-rtc-manager (Diagnostic, DiagnosticCaller, Counter,
Sink, Robot) and urs-bridge: rtls -lR, rtcat -ll, rtact/rtdeact/rtreset, rtcon/rtdis (data and
service ports), rtconf list/get/set/act, rtcryo/rtteardown/rtresurrect and rtexit.

rtshell exits 0 on some failures, so every step asserts its effect (a state, a connection, a
value read back with `urs rtc` or a service call), not rtshell's exit status.

Usage: rtshell_test.py --urs BIN --rtc-manager BIN --bridge BIN --omninames BIN --work DIR --venv DIR
"""

import argparse
import fcntl
import glob
import json
import os
import random
import re
import socket
import subprocess
import sys
import time
import traceback

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "support"))
from dds_domain import lock_dds_domain  # noqa: E402  (the lock every test linking spaces takes)

PACKAGES = ["rtshell-aist==4.2.10", "rtctree-aist==4.2.5", "rtsprofile-aist==4.1.6", "salome-omniorb==4.2.5",
            # rtsprofile imports yaml without declaring it
            "PyYAML"]
STEP_TIMEOUT = 60  # s, bound on one command



def remove_stale(path):
    """Removes a ready file an earlier run left in the reused work folder, so that waiting for it
    waits for this run's process."""
    if os.path.exists(path):
        os.remove(path)

class Failure(Exception):
    pass


def log(text):
    print(text, flush=True)


def run(argv, env=None, timeout=STEP_TIMEOUT, check=False):
    result = subprocess.run(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            timeout=timeout)
    log("$ " + " ".join(argv) + f"  -> {result.returncode}")
    for stream in (result.stdout, result.stderr):
        if stream.strip():
            log("  " + stream.strip().replace("\n", "\n  "))
    if check and result.returncode != 0:
        raise Failure(f"{argv[0]} exited {result.returncode}")
    return result


def wait_until(what, condition, timeout=20.0):
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise Failure(f"timed out waiting for {what}")
        time.sleep(0.1)


# ---- the peer: a cached virtual environment ---------------------------------------------------

def ensure_venv(venv):
    """Creates (or reuses) the venv; a lock keeps two runs from building it at once."""
    marker = os.path.join(venv, "urs-ready")
    wanted = "\n".join(PACKAGES) + "\n"
    os.makedirs(os.path.dirname(venv) or ".", exist_ok=True)
    with open(venv + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if os.path.exists(marker) and open(marker).read() == wanted:
            log(f"reusing {venv}")
            return
        log(f"creating {venv}")
        run([sys.executable, "-m", "venv", "--clear", venv], check=True)
        python = os.path.join(venv, "bin", "python")
        result = run([python, "-m", "pip", "install", "--disable-pip-version-check", "-q"] + PACKAGES,
                     timeout=600)
        if result.returncode != 0:
            raise Failure("pip could not install " + " ".join(PACKAGES) + " (PyPI must be reachable)")
        # The top-level RTC, SDOPackage and OpenRTM modules, from the IDL rtctree ships.
        compile_idl = (
            "import glob, os, sys, rtctree\n"
            "from omniidl import main\n"
            "idl = os.path.join(os.path.dirname(rtctree.__file__), 'data', 'idl')\n"
            "site = os.path.dirname(os.path.dirname(rtctree.__file__))\n"
            "sys.argv = ['omniidl', '-bpython', '-C', site, '-I' + idl] + sorted(glob.glob(idl + '/*.idl'))\n"
            "main.main()\n")
        run([python, "-c", compile_idl], check=True)
        with open(marker, "w") as out:
            out.write(wanted)


# ---- the space under test ---------------------------------------------------------------------

def free_port():
    for _ in range(100):
        port = random.randint(20000, 32000)
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
                return port
            except OSError:
                continue
    raise Failure("no free TCP port")


class Space:
    def __init__(self, args):
        self.args = args
        self.work = args.work
        self.processes = []
        self.port = None

    def start(self, argv, log_name):
        out = open(os.path.join(self.work, log_name), "w")
        process = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT)
        self.processes.append((process, log_name))
        return process

    def start_naming(self):
        for _ in range(5):
            self.port = free_port()
            data = os.path.join(self.work, f"omninames-{self.port}")
            os.makedirs(data, exist_ok=True)
            process = self.start([self.args.omninames, "-start", str(self.port), "-datadir", data, "-ORBendPoint",
                                  f"giop:tcp:127.0.0.1:{self.port}"], "omninames.log")
            try:
                wait_until("omniNames", lambda: process.poll() is not None or
                           "Root context is" in open(os.path.join(self.work, "omninames.log")).read(), 10)
            except Failure:
                pass
            if process.poll() is None:
                return
        raise Failure("omniNames did not start")

    def start_manager(self, config_text):
        config = os.path.join(self.work, "manager.yaml")
        ready = os.path.join(self.work, "manager.ready")
        with open(config, "w") as out:
            out.write(config_text)
        remove_stale(ready)
        process = self.start([self.args.rtc_manager, "--space", "lab", "--naming", f"127.0.0.1:{self.port}",
                              "--host", "testhost", "--config", config, "--ready-file", ready], "manager.log")
        wait_until("urs-rtc-manager", lambda: os.path.exists(ready) or process.poll() is not None)
        if process.poll() is not None:
            raise Failure("urs-rtc-manager exited")

    def start_bridge(self):
        config = os.path.join(self.work, "bridge.yaml")
        ready = os.path.join(self.work, "bridge.ready")
        with open(config, "w") as out:
            out.write("name: bridge-rtshell\nactivate: false\n")
        remove_stale(ready)
        process = self.start([self.args.bridge, "--space", "lab", "--naming", f"127.0.0.1:{self.port}", "--host",
                              "bridgehost", "--config", config, "--ready-file", ready], "bridge.log")
        wait_until("urs-bridge", lambda: os.path.exists(ready) or process.poll() is not None)
        if process.poll() is not None:
            raise Failure("urs-bridge exited")

    def stop(self):
        for process, _ in reversed(self.processes):
            if process.poll() is None:
                process.terminate()
        for process, _ in reversed(self.processes):
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()

    def dump_logs(self):
        for _, name in self.processes:
            log(f"---- {name}")
            log(open(os.path.join(self.work, name)).read()[-6000:])


# ---- the test ---------------------------------------------------------------------------------

class RtshellTest:
    def __init__(self, args, space):
        self.args = args
        self.space = space
        self.env = dict(os.environ)
        self.env["RTCTREE_NAMESERVERS"] = f"127.0.0.1:{space.port}"
        # Bounded calls: a tool must not hang on a component that does not answer.
        self.env["RTCTREE_ORB_ARGS"] = "rtshell;-ORBclientCallTimeOutPeriod;10000;-ORBclientConnectTimeOutPeriod;2000"
        self.bin = os.path.join(args.venv, "bin")
        self.root = f"/127.0.0.1:{space.port}"
        self.failures = []

    def rtshell(self, tool, *arguments):
        return run([os.path.join(self.bin, tool)] + list(arguments), env=self.env)

    def urs(self, *arguments):
        return run([self.args.urs, "rtc", "--naming", f"127.0.0.1:{self.space.port}"] + list(arguments))

    def path(self, instance, host="testhost"):
        return f"{self.root}/{host}.host_cxt/{instance}.rtc"

    @staticmethod
    def naming_path(instance, host="testhost"):
        return f"{host}.host_cxt/{instance}.rtc"

    def state(self, instance, host="testhost"):
        out = self.urs("ls", self.naming_path(instance, host)).stdout
        return out.split()[-1] if out.strip() else ""

    def connections(self, instance, port, host="testhost"):
        out = self.urs("cat", f"{self.naming_path(instance, host)}:{port}").stdout
        found = re.search(r"^  (\d+) connections?", out, re.M)
        return int(found.group(1)) if found else -1

    def manager_log(self):
        with open(os.path.join(self.space.work, "manager.log")) as f:
            return f.read()

    def conf(self, instance, name):
        return self.urs("conf", "get", self.naming_path(instance), name).stdout.strip()

    def check(self, what, got, expected):
        if got == expected:
            log(f"ok: {what}")
        else:
            self.failures.append(f"{what}: got {got!r}, expected {expected!r}")
            log(f"FAILED: {what}: got {got!r}, expected {expected!r}")

    # Each step asserts what rtshell did, read back through URSLink's own tool.

    def listing(self):
        out = self.rtshell("rtls", "-lR", self.root + "/").stdout
        for instance in ["Counter0", "Sink0", "Diagnostic0", "DiagnosticCaller0", "Robot0"]:
            self.check(f"rtls -lR lists {instance} Inactive",
                       bool(re.search(r"^Inactive .*\b" + instance + r"\.rtc$", out, re.M)), True)
        self.check("rtls -lR lists the bridge", bool(re.search(r"Bridge0\.rtc$", out, re.M)), True)
        out = self.rtshell("rtcat", "-ll", self.path("Counter0")).stdout
        self.check("rtcat -ll shows the instance", "Instance name  Counter0" in out, True)
        self.check("rtcat -ll shows the count port and its type",
                   bool(re.search(r"DataOutPort: count\n(.*\n)*?\s+dataport.data_type\s+IDL:RTC/TimedLong:1.0", out)), True)
        out = self.rtshell("rtcat", "-ll", self.path("Bridge0", "bridgehost")).stdout
        self.check("rtcat -ll shows the bridge's provider port", "CorbaPort: providers" in out, True)

    def lifecycle(self):
        self.rtshell("rtact", self.path("Counter0"))
        self.check("rtact makes Counter0 Active", self.state("Counter0"), "Active")
        self.rtshell("rtdeact", self.path("Counter0"))
        self.check("rtdeact makes Counter0 Inactive", self.state("Counter0"), "Inactive")
        # A strict caller with no provider fails its first execution: Error, until rtreset.
        self.rtshell("rtconf", self.path("DiagnosticCaller0"), "set", "strict", "true")
        self.check("rtconf set strict", self.conf("DiagnosticCaller0", "strict"), "true")
        self.rtshell("rtact", self.path("DiagnosticCaller0"))
        self.check("a strict caller without provider goes to Error (rtconf set took effect)",
                   wait_until("Error", lambda: self.state("DiagnosticCaller0") == "Error" and "Error", 5), "Error")
        self.rtshell("rtreset", self.path("DiagnosticCaller0"))
        self.check("rtreset makes it Inactive", self.state("DiagnosticCaller0"), "Inactive")
        self.rtshell("rtconf", self.path("DiagnosticCaller0"), "set", "strict", "false")
        # The bridge's RTC too: activating it starts the bridge, deactivating stops it.
        self.rtshell("rtact", self.path("Bridge0", "bridgehost"))
        self.check("rtact on the bridge", self.state("Bridge0", "bridgehost"), "Active")
        self.rtshell("rtdeact", self.path("Bridge0", "bridgehost"))
        self.check("rtdeact on the bridge", self.state("Bridge0", "bridgehost"), "Inactive")

    def connections_made_and_removed(self):
        self.rtshell("rtcon", self.path("Counter0") + ":count", self.path("Sink0") + ":count")
        self.check("rtcon joins data ports (out side)", self.connections("Counter0", "count"), 1)
        self.check("rtcon joins data ports (in side)", self.connections("Sink0", "count"), 1)
        self.rtshell("rtcon", self.path("DiagnosticCaller0") + ":diagnostic", self.path("Diagnostic0") + ":diagnostic")
        self.check("rtcon joins service ports", self.connections("Diagnostic0", "diagnostic"), 1)
        # With the provider connected, the strict caller stays Active: its echo calls work.
        self.rtshell("rtconf", self.path("DiagnosticCaller0"), "set", "strict", "true")
        replies_before = self.manager_log().count("DiagnosticCaller0: first echo reply")
        self.rtshell("rtact", self.path("DiagnosticCaller0"))
        # An execution has called through (without a provider, a strict caller fails at once).
        wait_until("the caller's first echo reply",
                   lambda: self.manager_log().count("DiagnosticCaller0: first echo reply") > replies_before)
        self.check("a connected strict caller stays Active", self.state("DiagnosticCaller0"), "Active")
        self.rtshell("rtdeact", self.path("DiagnosticCaller0"))
        self.rtshell("rtconf", self.path("DiagnosticCaller0"), "set", "strict", "false")
        # (rtcon refuses the bridge's `providers` port: rtctree wants interfaces of the same
        # instance names on both ports, and that port declares none; `urs rtc con` connects it.)

    def configuration(self):
        out = self.rtshell("rtconf", self.path("Counter0"), "list", "-l").stdout
        self.check("rtconf list shows the active set and radius",
                   bool(re.search(r"default\*", out)) and bool(re.search(r"^\s+radius\s+1$", out, re.M)), True)
        self.check("rtconf get", self.rtshell("rtconf", self.path("Counter0"), "get", "radius").stdout.strip(), "1")
        self.rtshell("rtconf", self.path("Counter0"), "set", "radius", "2.5")
        self.check("rtconf set radius 2.5 is stored", self.conf("Counter0", "radius"), "2.5")
        result = self.rtshell("rtconf", self.path("Counter0"), "set", "radius", "wide")
        self.check("rtconf set of a bad value is refused with the reason", "'wide' is not a number" in result.stderr, True)
        self.check("... and changes nothing", self.conf("Counter0", "radius"), "2.5")
        # A device parameter takes effect in the device: the robot's cruise speed (mm/s).
        self.rtshell("rtconf", self.path("Robot0"), "set", "speed", "250")
        reply = self.urs("call", self.naming_path("Robot0") + ":navigation", "_get_speed").stdout.strip()
        self.check("rtconf set speed reaches the robot", json.loads(reply or "{}").get("result"), 250)
        result = self.rtshell("rtconf", self.path("Robot0"), "set", "speed", "99999")
        reply = self.urs("call", self.naming_path("Robot0") + ":navigation", "_get_speed").stdout.strip()
        self.check("a speed above max_speed is refused", json.loads(reply or "{}").get("result"), 250)
        result = self.rtshell("rtconf", self.path("Bridge0", "bridgehost"), "set", "planet_peer", "other")
        self.check("a read-only parameter is refused", "read-only" in result.stderr, True)
        # Sets: one added with `urs rtc conf`, activated with rtconf act.
        self.rtshell("rtconf", self.path("Counter0"), "-s", "default", "set", "period", "10")
        self.urs("conf", "set", self.naming_path("Counter0"), "radius", "4")
        self.rtshell("rtconf", self.path("Counter0"), "-s", "default", "act")
        self.check("rtconf act of the active set keeps its values", self.conf("Counter0", "radius"), "4")

    def cryo_and_resurrect(self):
        system = os.path.join(self.space.work, "system.rtsys")
        self.rtshell("rtcryo", f"127.0.0.1:{self.space.port}", "-o", system)
        self.check("rtcryo wrote the system", os.path.exists(system) and "Counter0" in open(system).read(), True)
        self.rtshell("rtteardown", system)
        self.check("rtteardown removes the data connection", self.connections("Sink0", "count"), 0)
        self.check("rtteardown removes the service connection", self.connections("Diagnostic0", "diagnostic"), 0)
        self.urs("conf", "set", self.naming_path("Counter0"), "radius", "9")
        self.rtshell("rtresurrect", system)
        self.check("rtresurrect restores the data connection", self.connections("Sink0", "count"), 1)
        self.check("rtresurrect restores the service connection", self.connections("Diagnostic0", "diagnostic"), 1)
        self.check("rtresurrect restores the configuration", self.conf("Counter0", "radius"), "4")
        self.rtshell("rtdis", self.path("Counter0") + ":count", self.path("Sink0") + ":count")
        self.check("rtdis removes the data connection", self.connections("Counter0", "count"), 0)
        self.rtshell("rtdis", self.path("DiagnosticCaller0") + ":diagnostic", self.path("Diagnostic0") + ":diagnostic")
        self.check("rtdis removes the service connection", self.connections("DiagnosticCaller0", "diagnostic"), 0)

    def exit(self):
        self.rtshell("rtexit", self.path("Sink0"))
        gone = wait_until("Sink0 unbound", lambda: "Sink0" not in self.urs("ls", "testhost.host_cxt").stdout, 10)
        self.check("rtexit: the component exits and its binding goes", gone, True)
        self.check("the others stay", self.state("Counter0"), "Inactive")


def main():
    parser = argparse.ArgumentParser()
    for name in ["--urs", "--rtc-manager", "--bridge", "--omninames", "--work", "--venv"]:
        parser.add_argument(name, required=True)
    args = parser.parse_args()
    os.makedirs(args.work, exist_ok=True)
    ensure_venv(args.venv)
    domain, domain_lock = lock_dds_domain()
    space = Space(args)
    try:
        space.start_naming()
        space.start_manager("components:\n"
                            "  - type: Diagnostic\n"
                            "  - type: DiagnosticCaller\n"
                            "  - type: Counter\n"
                            "  - type: Sink\n"
                            "  - type: Robot\n"
                            f"    config: {{params: {{name: rtshell-robot-{os.getpid()}, domain: {domain}, "
                            "feedback: ground_truth}}\n")
        space.start_bridge()
        test = RtshellTest(args, space)
        for step in [test.listing, test.lifecycle, test.connections_made_and_removed, test.configuration,
                     test.cryo_and_resurrect, test.exit]:
            log(f"==== {step.__name__}")
            try:
                step()
            except (Failure, subprocess.TimeoutExpired) as e:
                test.failures.append(f"{step.__name__}: {e}")
                log(traceback.format_exc())
        if test.failures:
            space.dump_logs()
            log("\n".join(["rtshell test failed:"] + test.failures))
            return 1
        log("rtshell test passed")
        return 0
    finally:
        space.stop()
        domain_lock.close()


if __name__ == "__main__":
    sys.exit(main())
