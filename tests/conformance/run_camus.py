#!/usr/bin/python3
"""Runs the Planet conformance suite against a real urs-camus-server (with named credentials of
each role) and a urs-sam hosting the diagnostic agent, all on loopback; stops them afterwards.

  run_camus.py --server-bin B --sam-bin B --pythonpath DIRS [--tls] [--keep]
With --tls every connection is TLS 1.3 (a CA and a server certificate made with openssl).
Exit status: the suite's (0 if every check passed or was skipped), 2 if the space did not start.
"""
import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def wait_for(condition, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return False


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--sam-bin", required=True)
    parser.add_argument("--pythonpath", required=True)
    parser.add_argument("--keep", action="store_true", help="keep the work folder (logs)")
    parser.add_argument("--tls", action="store_true", help="run the space and the suite over TLS 1.3")
    args = parser.parse_args()

    work = tempfile.mkdtemp(prefix="planet-conformance-")
    tokens = {}
    for role in ("client", "sam", "operator"):
        tokens[role] = os.path.join(work, role + ".token")
        with open(tokens[role], "w") as f:
            f.write("%s-%d-%s\n" % (role, os.getpid(), os.urandom(8).hex()))
    with open(os.path.join(work, "credentials.yaml"), "w") as f:
        f.write("credentials:\n")
        for role in tokens:
            f.write("  - name: conformance-%s\n    role: %s\n    token_file: %s.token\n" % (role, role, role))
    with open(os.path.join(work, "sam.yaml"), "w") as f:
        f.write("agents:\n  - name: diag\n    type: diagnostic\n    deadline_ms: 5000\n")

    server_tls, client_tls = [], []
    if args.tls:
        ca, key, cert = (os.path.join(work, n) for n in ("ca.pem", "server.key", "server.pem"))
        with open(os.path.join(work, "san.cnf"), "w") as f:
            f.write("subjectAltName=IP:127.0.0.1\n")
        ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
        for argv in (["req", "-x509"] + ec + ["-days", "2", "-subj", "/CN=conformance-ca", "-keyout",
                                            os.path.join(work, "ca.key"), "-out", ca],
                     ["req"] + ec + ["-subj", "/CN=conformance", "-keyout", key, "-out", cert + ".csr"],
                     ["x509", "-req", "-in", cert + ".csr", "-CA", ca, "-CAkey", os.path.join(work, "ca.key"),
                      "-CAcreateserial", "-days", "2", "-extfile", os.path.join(work, "san.cnf"), "-out", cert]):
            subprocess.run(["openssl"] + argv, check=True, capture_output=True, timeout=60)
        server_tls = ["--tls-cert", cert, "--tls-key", key]
        client_tls = ["--tls-ca", ca]

    processes = []
    logs = []

    def start(argv, name):
        log = open(os.path.join(work, name + ".log"), "w")
        logs.append(log)
        processes.append(subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT))

    code = 2
    try:
        port_file = os.path.join(work, "port")
        start([args.server_bin, "--space", "conformance", "--listen", "127.0.0.1:0", "--port-file", port_file,
               "--credentials", os.path.join(work, "credentials.yaml"), "--max-pending-calls-per-session", "20",
               "--log-level", "info"] + server_tls, "server")
        if not wait_for(lambda: os.path.exists(port_file), 20):
            print("the server did not start; see", work)
            return 2
        with open(port_file) as f:
            server = "127.0.0.1:" + f.read().strip()
        start([args.sam_bin, "--space", "conformance", "--server", server, "--config", os.path.join(work, "sam.yaml"),
               "--token-file", tokens["sam"], "--log-level", "info"] + client_tls, "sam")
        if not wait_for(lambda: "service diag" in open(os.path.join(work, "server.log")).read(), 30):
            print("the SAM did not register diag; see", work)
            return 2
        env = dict(os.environ, PYTHONPATH=HERE)
        suite = subprocess.run(
            [sys.executable, "-m", "planet", "--server", server, "--token-file", tokens["client"],
             "--sam-token-file", tokens["sam"], "--operator-token-file", tokens["operator"],
             "--limit", "max_pending_calls_per_session=20", "--pythonpath", args.pythonpath] + client_tls,
            env=env, timeout=240)
        code = suite.returncode
        return code
    finally:
        for p in processes:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in processes:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for log in logs:
            log.close()
        if code != 0:
            for name in ("server", "sam"):
                path = os.path.join(work, name + ".log")
                if os.path.exists(path):
                    print("---- %s log (tail)" % name)
                    print(open(path).read()[-4000:])
        if args.keep or code == 2:
            print("work folder:", work)
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
