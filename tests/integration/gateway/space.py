"""A local space holding both middlewares, as real processes on loopback, with urs-gateway attached:
omniNames, urs-camus-server (with a token and the square-path task), urs-sam (the diagnostic agent,
and the robot, its localizer and a camera riding on it as CAMUS agents, so the square-path task's
and the camera's events reach CAMUS),
urs-rtc-manager (camera, Diagnostic provider and caller wired by a connector), urs-bridge (the
camera RTC as a CAMUS service, the diagnostic agent as an RTC) and urs-gateway. Every wait is bounded; stop() ends every process this fixture started (and only them).

    with Space(build_dir, source_dir, "conformance") as space:
        space.gateway_url  ->  "ws://127.0.0.1:PORT/"
"""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "support"))
from dds_domain import lock_dds_domain  # noqa: E402  (the lock every test linking spaces takes)

TOKEN = "gateway-test-token"
VIEWER_TOKEN = "gateway-test-viewer"
# Credentials the CAMUS server itself gives lesser roles (--credentials): the gateway makes their
# logins viewers, from the role in the server's Welcome.
CLIENT_TOKEN = "gateway-test-client"
SAM_TOKEN = "gateway-test-sam"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what, condition, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise TimeoutError("%s did not happen within %s s" % (what, timeout))


class Space:
    def __init__(self, build, source, name, time_scale=4, localizer_rate=10, extra_gateway_args=(), link_domain=None,
                 all_devices=False):
        """link_domain: a DDS domain shared with other spaces; the bridge links the space there
        (exporting everything, importing the others' services as CAMUS services <space>/<name>,
        sharing its components, robot poses and events) and the gateway reads it.
        all_devices: the SAM hosts the speech devices too (tts1, voice1) and the example C++
        plug-in's calculator (calc), and the Python SDK example's agent serves thermo."""
        self.link_domain = link_domain
        self.all_devices = all_devices
        self.build = build
        self.source = source
        self.name = name
        self.time_scale = time_scale
        self.localizer_rate = localizer_rate
        self.extra_gateway_args = list(extra_gateway_args)
        self.procs = {}
        self.dir = tempfile.mkdtemp(prefix="urs-gateway-%s-" % name)

    # ---- processes ----
    def bin(self, path):
        return os.path.join(self.build, "services", path)

    def start(self, name, argv):
        log = open(os.path.join(self.dir, name + ".log"), "ab")
        self.procs[name] = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        return self.procs[name]

    def log(self, name):
        try:
            with open(os.path.join(self.dir, name + ".log"), errors="replace") as f:
                return f.read()
        except OSError:
            return ""

    def alive(self, name):
        return self.procs[name].poll() is None

    def __enter__(self):
        # SIGTERM (a test runner's timeout, kill) ends the space like an exception: nothing left running.
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
        try:
            self.up()
        except BaseException:
            self.dump_logs()
            self.stop()
            raise
        return self

    def __exit__(self, kind, value, tb):
        if kind is not None:
            self.dump_logs()
        self.stop()
        return False

    def dump_logs(self):
        for name in self.procs:
            print("---- %s log (last 60 lines)" % name)
            print("\n".join(self.log(name).splitlines()[-60:]))

    def stop(self):
        for name, proc in reversed(list(self.procs.items())):
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for name, proc in reversed(list(self.procs.items())):
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5)
        if getattr(self, "domain_lock", None):
            self.domain_lock.close()
        if os.environ.get("URS_KEEP_TEST_DIR") is None:
            shutil.rmtree(self.dir, ignore_errors=True)

    def up(self):
        self.domain, self.domain_lock = lock_dds_domain()
        d = self.dir
        with open(os.path.join(d, "token"), "w") as f:
            f.write(TOKEN + "\n")
        with open(os.path.join(d, "viewer-token"), "w") as f:
            f.write(VIEWER_TOKEN + "\n")
        for name, token in (("watcher", CLIENT_TOKEN), ("agent-host", SAM_TOKEN)):
            with open(os.path.join(d, name + ".token"), "w") as f:
                f.write(token + "\n")
        with open(os.path.join(d, "credentials.yaml"), "w") as f:
            f.write("credentials:\n"
                    "  - {name: watcher, role: client, token_file: watcher.token}\n"
                    "  - {name: agent-host, role: sam, token_file: agent-host.token}\n")
        naming_port = free_port()
        self.naming = "127.0.0.1:%d" % naming_port
        os.makedirs(os.path.join(d, "naming"))
        self.start("omniNames", ["omniNames", "-start", str(naming_port), "-datadir", os.path.join(d, "naming"),
                                 "-logdir", os.path.join(d, "naming"), "-ORBendPoint", "giop:tcp:" + self.naming])
        wait_for("omniNames listening", lambda: self.accepts(naming_port), 15)
        tasks = os.path.join(self.source, "services", "camus-server", "tasks")
        self.start("server", [self.bin("camus-server/urs-camus-server"), "--space", self.name, "--listen", "127.0.0.1:0",
                              "--port-file", os.path.join(d, "port"), "--data-dir", os.path.join(d, "data"),
                              "--tasks-dir", tasks, "--token-file", os.path.join(d, "token"), "--token-role", "operator",
                              "--credentials", os.path.join(d, "credentials.yaml")])
        wait_for("urs-camus-server listening", lambda: os.path.exists(os.path.join(d, "port")), 15)
        self.server = "127.0.0.1:" + open(os.path.join(d, "port")).read().strip()
        params = {"domain": self.domain, "scale": self.time_scale, "rate": self.localizer_rate}
        rtc_yaml = os.path.join(d, "rtc.yaml")
        with open(rtc_yaml, "w") as f:
            f.write("""rate: 100
components:
  - type: Camera
    config: {params: {pose: {x: 3.25, y: 2.0, theta: 0.0}}}
  - type: Diagnostic
  - type: DiagnosticCaller
  - type: Connector
    activate: true
    config:
      poll_ms: 200
      rules:
        - interface: URS::Diagnostic
""")
        sam_yaml = os.path.join(d, "sam.yaml")
        with open(sam_yaml, "w") as f:
            if self.all_devices:
                f.write("plugins: [%s]\n" % os.path.join(self.build, "tests", "integration", "plugin",
                                                         "libtest_calculator_plugin.so"))
            f.write("""agents:
  - {name: diag, type: diagnostic, deadline_ms: 5000}
  - name: robot1.navigation
    type: robot
    params: {name: robot1, prefix: robot1.navigation, domain: %(domain)d, time_scale: %(scale)s, x: 1.5, y: 1.0}
  - name: robot1.localizer
    type: localizer
    params: {robot: robot1, prefix: loc1, domain: %(domain)d, time_scale: %(scale)s, rate: %(rate)s}
  - name: camera1
    type: camera
    params: {event_prefix: camera1, scan_hz: 2, world: {domain: %(domain)d, robot: robot1}}
""" % params)
            if self.all_devices:
                f.write("""  - {name: tts1, type: tts, deadline_ms: 20000, params: {}}
  - {name: voice1, type: voice, deadline_ms: 20000, params: {}}
  - {name: calc, type: calculator, params: {label: %s-calc}}
""" % self.name)
        bridge_yaml = os.path.join(d, "bridge.yaml")
        with open(bridge_yaml, "w") as f:
            f.write("""name: bridge-lab
rt_to_camus:
  poll_ms: 200
  providers:
    - {match: "*/Camera0.rtc", name: camera, deadline_ms: 10000}
camus_to_rt:
  poll_ms: 300
  services:
    - {match: diag, instance: "camus_{service}"}
""")
            if self.link_domain is not None:
                f.write("""dds:
  domain: %(link)d
  lease_ms: 3000
  export: {allow: ["*"], deny: ["camus.*"]}
  import: {as_camus: "{space}/{service}", as_rtc: ""}
  state:
    components: true
    poses: {domain: %(domain)d, source: localizer, robots: [robot1], period_ms: 100}
    events: ["robot1.navigation/#"]
""" % dict(params, link=self.link_domain))
        self.start("rtc-manager", [self.bin("rtc-manager/urs-rtc-manager"), "--space", self.name, "--naming",
                                   self.naming, "--host", "labpc", "--config", rtc_yaml, "--ready-file",
                                   os.path.join(d, "rtc.ready")])
        wait_for("urs-rtc-manager up", lambda: os.path.exists(os.path.join(d, "rtc.ready")), 40)
        self.start("sam", [self.bin("sam/urs-sam"), "--space", self.name, "--server", self.server, "--config",
                           sam_yaml, "--token-file", os.path.join(d, "token")])
        if self.all_devices:
            self.start("thermostat", ["/usr/bin/python3", os.path.join(self.source, "examples", "python",
                                                                      "thermostat_agent.py"),
                                      "--server", self.server, "--token-file", os.path.join(d, "agent-host.token"),
                                      "--name", "thermo"])
        self.start("bridge", [self.bin("bridge/urs-bridge"), "--space", self.name, "--server", self.server,
                              "--naming", self.naming, "--host", "labpc", "--config", bridge_yaml, "--token-file",
                              os.path.join(d, "token"), "--ready-file", os.path.join(d, "bridge.ready")])
        self.start("gateway", [self.bin("gateway/urs-gateway"), "--space", self.name, "--server", self.server,
                               "--naming", self.naming, "--listen", "127.0.0.1:0", "--port-file",
                               os.path.join(d, "gateway.port"), "--token-file", os.path.join(d, "token"),
                               "--viewer-token-file", os.path.join(d, "viewer-token"), "--devices-domain",
                               str(self.domain), "--robots", "robot1", "--rt-poll-ms", "500"]
                   + (["--dds-domain", str(self.link_domain)] if self.link_domain is not None else [])
                   + self.extra_gateway_args)
        wait_for("urs-gateway listening", lambda: os.path.exists(os.path.join(d, "gateway.port")), 20)
        self.gateway_port = int(open(os.path.join(d, "gateway.port")).read().strip())
        self.http_url = "http://127.0.0.1:%d/" % self.gateway_port
        self.gateway_url = "ws://127.0.0.1:%d/" % self.gateway_port

    @staticmethod
    def accepts(port):
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return True
        except OSError:
            return False

    # ---- helpers ----
    def urs(self, *args, timeout=30):
        return subprocess.run([self.bin("cli/urs"), "--server", self.server, "--token-file",
                               os.path.join(self.dir, "token")] + list(args), capture_output=True, text=True,
                              timeout=timeout)

    def login(self, credential):
        """POST /api/login; returns (status, body dict)."""
        request = urllib.request.Request(self.http_url + "api/login", data=json.dumps({"credential": credential}).encode(),
                                         headers={"Content-Type": "application/json"}, method="POST")
        try:
            with urllib.request.urlopen(request, timeout=10) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as e:
            return e.code, json.loads(e.read() or b"{}")


if __name__ == "__main__":
    # By hand: space.py BUILD_DIR SOURCE_DIR [SECONDS [SPACE...]] — local spaces with their
    # gateways (one named "lab" by default; several are linked over a DDS domain of their own),
    # left running for SECONDS (default 600) or until Ctrl-C.
    import contextlib
    seconds = float(sys.argv[3]) if len(sys.argv) > 3 else 600
    names = sys.argv[4:] or ["lab"]
    link, link_lock = lock_dds_domain() if len(names) > 1 else (None, None)
    with contextlib.ExitStack() as stack:
        for name in names:
            space = stack.enter_context(Space(sys.argv[1], sys.argv[2], name, link_domain=link))
            print("%s: dashboard %s   Foxglove WebSocket %s   credential %s (viewer: %s)" %
                  (name, space.http_url, space.gateway_url, TOKEN, VIEWER_TOKEN), flush=True)
            print("%s: --server %s --naming %s (devices domain %d%s); logs in %s" %
                  (name, space.server, space.naming, space.domain,
                   ", link domain %d" % link if link is not None else "", space.dir), flush=True)
        try:
            time.sleep(seconds)
        except KeyboardInterrupt:
            pass
