#!/usr/bin/env python3
"""A space recorded to MCAP while the square-path task runs, read back, and played back through
the gateway (docs/dashboard.md, "Recording and playback"), with a real local space (space.py), the
real `urs record` / `urs play` commands and the `mcap` package from PyPI (in a venv,
tests/support/pypi_venv.sh; exit 77 — skipped — when PyPI cannot be reached):

  - the recording holds every channel the gateway advertised, each with the schema it advertised
    (byte for byte), chunked and indexed, and the task's run: its call on /calls with the reply,
    the robot's poses tracing the square (every corner within 0.2 m), the task's events;
  - a recorder rotating by size writes several files, each opening with the latched state;
  - a writer held as by a slow disk drops what exceeds its queue, counts it, and holds no more;
  - `urs play` serves the recording through urs-gateway --playback: the conformance client sees
    the catalog, the per-robot channel, the square traced again and the calls; a player's events
    re-published into a live space arrive there.

    recording_test.py BUILD_DIR SOURCE_DIR [SCREENSHOT_DIR]   (the dashboard playing: dashboard-playback.png)
"""
import asyncio
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CORNERS = [(1.5, 1.0), (1.5, 3.0), (5.0, 3.0), (5.0, 1.0)]


def check(ok, what):
    from conformance_test import check as checked  # imported once the venv runs this file
    return checked(ok, what)


def venv_python(build):
    """The venv's python (re-run under it, so that `mcap` imports here too)."""
    script = os.path.join(HERE, "..", "..", "support", "pypi_venv.sh")
    venv = os.path.join(build, "tests", "venv-mcap")
    done = subprocess.run([script, "--system-site-packages", venv, "mcap", "1.6.0"], stdout=subprocess.PIPE, text=True)
    if done.returncode == 77:
        print("SKIP: PyPI is not reachable: the mcap package cannot be installed")
        sys.exit(77)
    if done.returncode != 0:
        sys.exit("cannot make the mcap venv")
    return done.stdout.strip()


def corners_reached(points):
    """The greatest distance from a corner of the square to the closest point of `points`."""
    worst = 0.0
    for cx, cy in CORNERS:
        worst = max(worst, min(((x - cx) ** 2 + (y - cy) ** 2) ** 0.5 for x, y in points) if points else 1e9)
    return worst


def urs_env(space, python):
    env = dict(os.environ, URS_PYTHON=python, URS_PYTHON_SDK=os.path.join(space.source, "python"),
               URS_GATEWAY_BIN=space.bin("gateway/urs-gateway"))
    return env


async def run_square(space, client):
    """Runs the square-path task through the gateway (a call on /calls); waits for its success."""
    await client.call("camus.tasks/Run", {"name": "square-path"}, 1)
    kind, answer = await client.answer(1)
    assert kind == "ok", answer
    run_id = answer[3]["run_id"]
    events = client.channels()["/events"]
    await client.send({"op": "subscribe", "subscriptions": [{"id": 50, "channelId": events["id"]}]})

    def succeeded():
        for sub, _, message in client.data:
            if sub == 50 and message["topic"] == "task/square-path/%s" % run_id:
                if json.loads(message["payload"]).get("state") == "succeeded":
                    return True
        return False
    await client.until("the square-path run %s succeeded" % run_id, succeeded, 120)
    return run_id


def read_recording(paths):
    from mcap.reader import make_reader
    out = {"schemas": {}, "messages": {}, "chunks": 0, "indexed": True, "metadata": {}}
    for path in paths:
        with open(path, "rb") as f:
            reader = make_reader(f)
            summary = reader.get_summary()
            out["chunks"] += summary.statistics.chunk_count if summary and summary.statistics else 0
            out["indexed"] = out["indexed"] and bool(summary and summary.chunk_indexes)
            for record in reader.iter_metadata():
                out["metadata"].setdefault(record.name, []).append(dict(record.metadata))
            for schema, channel, message in reader.iter_messages(log_time_order=True):
                out["schemas"].setdefault(channel.topic, set()).add((schema.name, schema.encoding, schema.data.decode(),
                                                                     channel.message_encoding))
                out["messages"].setdefault(channel.topic, []).append(json.loads(message.data))
    return out


def slow_disk_check(directory):
    """A writer held (as by a disk that does not take the data) drops past its queue and counts."""
    import threading
    from urslink.recording import FileWriter
    writer = FileWriter(os.path.join(directory, "slow.mcap"), False, 64 * 1024, 16 * 1024, {"space": "t"})
    held = threading.Event()
    original = writer._write

    def slow_write(*args):
        held.wait(30)
        original(*args)
    writer._write = slow_write
    writer.start()
    channel = {"id": 1, "topic": "/poses", "schemaName": "urs.gateway.Pose", "schema": '{"type":"object"}'}
    payload = b'{"x":' + b"1" * 1000 + b"}"
    taken = sum(writer.put(channel, i, payload, i) for i in range(1000))
    check(taken < 100 and writer.dropped_total == 1000 - taken,
          "a held writer takes %d of 1000 messages of 1 KB into a 64 KiB queue and counts %d dropped" %
          (taken, writer.dropped_total))
    check(writer._waiting <= 64 * 1024, "what waits stays within the queue: %d bytes" % writer._waiting)
    held.set()
    writer.finish()
    recorded = read_recording(writer.paths())
    counts = recorded["metadata"].get("urslink.recorder", [{}])[0]
    check(len(recorded["messages"].get("/poses", [])) == taken and counts.get("dropped_total") == str(1000 - taken),
          "the file holds what was taken and says what was dropped: %s" % counts)


def dashboard_shot(url, out):
    """The dashboard of the playback gateway in headless Chromium, once its square is drawn:
    OUT/dashboard-playback.png (docs/dashboard.md shows it)."""
    from browser_test import browser_session, until
    from selenium.webdriver.common.by import By
    os.makedirs(out, exist_ok=True)
    with browser_session(out, "dashboard-playback-failed") as (driver, shot):
        driver.get(url)
        until("the playback badge", lambda: driver.find_element(By.ID, "connection").text == "playing a recording")
        until("the robot on the map", lambda: driver.execute_script(
            'return !!document.querySelector(\'g.robot[data-robot="rec/robot1"]\');'), 30)
        until("the square's waypoints reached on the plot", lambda: len(driver.find_elements(
            By.CSS_SELECTOR, "#waypoints tbody tr")) >= 4, 30)
        time.sleep(1)
        shot("dashboard-playback")


async def scenario(space, python, directory, screenshots):
    from conformance_test import Client
    from space import TOKEN
    env = urs_env(space, python)
    status, body = space.login(TOKEN)
    assert status == 200, body
    client = await Client.connect(space.gateway_url + "?session=" + body["session"])
    robot_topic = "/%s/robot1/pose" % space.name
    await client.until("the channels, the robot's own among them", lambda: robot_topic in client.channels(), 30)
    await client.until("the task service", lambda: "camus.tasks/Run" in client.services(), 30)
    live = client.channels()

    # Two recorders: one file, and one rotating past 48 KiB.
    token_file = os.path.join(space.dir, "token")
    whole = os.path.join(directory, "square.mcap")
    rotated = os.path.join(directory, "rotated.mcap")
    urs = space.bin("cli/urs")
    recorders = [subprocess.Popen([urs, "record", "--gateway", space.http_url, "--credential-file", token_file,
                                   "-o", whole], env=env, stdout=subprocess.PIPE, text=True),
                 subprocess.Popen([urs, "record", "--gateway", space.http_url, "--credential-file", token_file,
                                   "-o", rotated, "--max-bytes", str(48 * 1024), "--chunk-kib", "8"],
                                  env=env, stdout=subprocess.PIPE, text=True)]
    await asyncio.sleep(2)  # both have subscribed (the latched state is theirs at once)
    await client.call("camus.context/Set", {"key": "lab/recording", "value": json.dumps({"by": "test"})}, 2)
    check((await client.answer(2))[0] == "ok", "a context entry is set")
    run_id = await run_square(space, client)
    await asyncio.sleep(1)
    summaries = []
    for recorder in recorders:
        recorder.send_signal(signal.SIGINT)
        out, _ = recorder.communicate(timeout=30)
        check(recorder.returncode == 0, "urs record ends cleanly on SIGINT (exit %s)" % recorder.returncode)
        summaries.append(json.loads(out.strip().splitlines()[-1]))
    print("recorders: %s" % summaries, flush=True)

    # Read back with the mcap reader.
    recorded = read_recording([whole])
    check(set(live) <= set(recorded["messages"]), "every live channel is recorded: missing %s" %
          sorted(set(live) - set(recorded["messages"])))
    for topic, channel in live.items():
        schemas = recorded["schemas"].get(topic, set())
        check(schemas == {(channel["schemaName"], "jsonschema", channel["schema"], "json")},
              "%s: recorded with the live schema (jsonschema, json)" % topic)
    check(recorded["chunks"] > 0 and recorded["indexed"], "the file is chunked (%d) and indexed" % recorded["chunks"])
    space_meta = recorded["metadata"].get("urslink.recording", [{}])[0]
    check(space_meta.get("space") == space.name, "the file names its space: %s" % space_meta)
    poses = [(p["x"], p["y"]) for p in recorded["messages"].get("/poses", []) if p["robot"] == "robot1"]
    worst = corners_reached(poses)
    check(worst < 0.2, "the recorded poses trace the square: every corner within %.3f m (%d poses)" % (worst, len(poses)))
    calls = [c for c in recorded["messages"].get("/calls", []) if c["service"] == "camus.tasks/Run"]
    check(calls and calls[0]["ok"] and json.loads(calls[0]["reply"])["run_id"] == run_id and
          json.loads(calls[0]["request"]) == {"name": "square-path"}, "the task's call is recorded with its reply")
    task_events = [e for e in recorded["messages"].get("/events", []) if e["topic"] == "task/square-path/" + run_id]
    check(task_events, "the task's events are recorded")
    rotated_files = summaries[1]["files"]
    check(len(rotated_files) >= 2, "the size-bounded recorder rotated: %s" % rotated_files)
    for path in rotated_files:
        part = read_recording([path])
        check("/services" in part["messages"] and "/components" in part["messages"],
              "%s opens with the latched state (/services, /components)" % os.path.basename(path))
        check(os.path.getsize(path) < 48 * 1024 * 3, "%s stays near its bound: %d bytes" % (path, os.path.getsize(path)))
    slow_disk_check(directory)

    # Playback through the gateway, read by the conformance client.
    port_file = os.path.join(directory, "play.port")
    player = subprocess.Popen([urs, "play", whole, "--speed", "2", "--listen", "127.0.0.1:0", "--port-file", port_file],
                              env=env, stdout=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while not os.path.exists(port_file) and time.monotonic() < deadline and player.poll() is None:
            await asyncio.sleep(0.05)
        check(os.path.exists(port_file), "urs play serves (exit %s)" % player.poll())
        url = "ws://127.0.0.1:%s/" % open(port_file).read().strip()
        viewer = await Client.connect(url)  # a playback gateway lets viewers in without a login
        info = (await viewer.until("serverInfo", lambda: viewer.of("serverInfo")))[0]
        check(info["metadata"].get("playback") == "true" and info["metadata"].get("space") == space.name,
              "the playback gateway names the recorded space: %s" % info["metadata"])
        await viewer.until("the recorded channels", lambda: {"/poses", "/services", "/calls"} <= set(viewer.channels()))
        played = viewer.channels()
        await viewer.send({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": played["/poses"]["id"]}, {"id": 2, "channelId": played["/services"]["id"]},
            {"id": 3, "channelId": played["/calls"]["id"]}]})
        await viewer.until("the catalog played",
                           lambda: [d for d in viewer.data if d[0] == 2 and any(s["name"] == "diag" for s in
                                                                                d[2]["services"])], 30)
        await viewer.until("the robot's own channel", lambda: robot_topic in viewer.channels(), 30)

        def square_again():
            points = [(d[2]["x"], d[2]["y"]) for d in viewer.data if d[0] == 1 and d[2]["robot"] == "robot1"]
            return corners_reached(points) < 0.2
        await viewer.until("the square traced again in playback", square_again, 90)
        if screenshots:
            dashboard_shot(url.replace("ws://", "http://"), screenshots)
        await viewer.until("the task's call played", lambda: [d for d in viewer.data if d[0] == 3 and
                                                              d[2]["service"] == "camus.tasks/Run"], 30)
        check(viewer.channels()[robot_topic]["schema"] == live[robot_topic]["schema"],
              "played channels have the live schemas")
        await viewer.ws.close()
    finally:
        player.send_signal(signal.SIGTERM)
        try:
            player.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            player.kill()
    check(player.returncode == 0, "urs play ends cleanly on SIGTERM (exit %s)" % player.returncode)

    # Events re-published into the live space, under a prefix of their own (on /events, which
    # run_square subscribed to as 50).
    done = subprocess.run([urs, "play", whole, "--speed", "0", "--then", "exit", "--publish-events", "--server",
                           space.server, "--token-file", token_file, "--events-prefix", "replay/", "--events-only"],
                          env=env, capture_output=True, text=True, timeout=120)
    check(done.returncode == 0, "urs play --publish-events ends: %s" % done.stderr[-2000:])
    await client.until("a re-published task event in the live space", lambda: [
        d for d in client.data if d[0] == 50 and d[2]["topic"] == "replay/task/square-path/" + run_id], 30)
    await client.ws.close()


def main():
    build, source = sys.argv[1], sys.argv[2]
    screenshots = sys.argv[3] if len(sys.argv) > 3 else None
    if os.environ.get("URS_RECORDING_TEST_VENV") is None:
        python = venv_python(build)
        os.execve(python, [python, os.path.abspath(__file__)] + sys.argv[1:],
                  dict(os.environ, URS_RECORDING_TEST_VENV=python))
    python = os.environ["URS_RECORDING_TEST_VENV"]
    sys.path.insert(0, HERE)
    sys.path.insert(0, os.path.join(source, "python"))
    from conformance_test import run_checks
    from space import Space
    directory = tempfile.mkdtemp(prefix="urs-recording-")
    print("recordings in %s" % directory, flush=True)
    run_checks(Space(build, source, "rec"), lambda space: scenario(space, python, directory, screenshots),
               "recording", 280)


if __name__ == "__main__":
    main()
