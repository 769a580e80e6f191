#!/usr/bin/env python3
"""Protocol conformance of urs-gateway against the Foxglove WebSocket protocol (foxglove/ws-protocol,
docs/spec.md), with a client written here (Python websockets) and a real local space (space.py):
serverInfo first; channels advertised with JSON schemas; subscribe / unsubscribe deliver exactly
what was asked; service calls answered (reply or typed failure), refused to a viewer; the
connection graph; bad input (bad JSON, unknown op, unknown channel, bad binary) refused with a
Status while the other client keeps receiving; no connection without a login.

    conformance_test.py BUILD_DIR SOURCE_DIR
"""
import asyncio
import json
import struct
import sys
import time
import urllib.error
import urllib.request

import websockets

from space import Space, TOKEN, VIEWER_TOKEN, CLIENT_TOKEN, SAM_TOKEN, wait_for

SUBPROTOCOL = "foxglove.websocket.v1"
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what, flush=True)
    return ok


class Client:
    """One WebSocket client that sorts what arrives: JSON ops and binary frames."""

    def __init__(self, ws):
        self.ws = ws
        self.ops = []          # every JSON message, in order
        self.data = []         # (subscription id, stamp ns, payload dict), in order
        self.responses = []    # (service id, call id, encoding, payload)
        self.task = asyncio.ensure_future(self.pump())

    @classmethod
    async def connect(cls, url):
        return cls(await websockets.connect(url, subprotocols=[SUBPROTOCOL], max_size=16 << 20))

    async def pump(self):
        try:
            async for message in self.ws:
                if isinstance(message, str):
                    self.ops.append(json.loads(message))
                elif message[0] == 0x01:
                    sub, stamp = struct.unpack_from("<IQ", message, 1)
                    self.data.append((sub, stamp, json.loads(message[13:])))
                elif message[0] == 0x03:
                    service, call, length = struct.unpack_from("<III", message, 1)
                    self.responses.append((service, call, message[13:13 + length].decode(),
                                           json.loads(message[13 + length:])))
        except websockets.ConnectionClosed:
            pass

    def of(self, op):
        return [m for m in self.ops if m.get("op") == op]

    async def until(self, what, condition, timeout=20):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            value = condition()
            if value:
                return value
            await asyncio.sleep(0.05)
        raise TimeoutError("%s within %s s" % (what, timeout))

    def _advertised(self, items, key, suffix=""):
        """The `items` ("channels", "services") advertised so far and not withdrawn, by their `key`:
        the lists of the "advertise<suffix>" messages less the ids in the "unadvertise<suffix>"
        messages' "<item>Ids"."""
        out = {}
        for message in self.of("advertise" + suffix):
            for item in message[items]:
                out[item[key]] = item
        for message in self.of("unadvertise" + suffix):
            gone = set(message[items[:-1] + "Ids"])
            out = {k: item for k, item in out.items() if item["id"] not in gone}
        return out

    def channels(self):
        return self._advertised("channels", "topic")

    def services(self):
        return self._advertised("services", "name", "Services")

    async def send(self, message):
        await self.ws.send(json.dumps(message) if isinstance(message, dict) else message)

    async def call(self, name, request, call_id):
        service = self.services()[name]
        encoding = b"json"
        await self.ws.send(struct.pack("<BIII", 0x02, service["id"], call_id, len(encoding)) + encoding +
                           json.dumps(request).encode())
        return service["id"]

    async def answer(self, call_id, timeout=20):
        def found():
            for response in self.responses:
                if response[1] == call_id:
                    return ("ok", response)
            for failure in self.of("serviceCallFailure"):
                if failure["callId"] == call_id:
                    return ("failure", failure)
            return None
        return await self.until("an answer to call %d" % call_id, found, timeout)

    def statuses(self):
        return [m for m in self.of("status")]


def post(url, body):
    """POST JSON; (status, body dict)."""
    request = urllib.request.Request(url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"},
                                     method="POST")
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read() or b"{}")


async def scenario(space):
    status, body = space.login("not the token")
    check(status == 401, "a wrong credential is refused with 401 (got %s %s)" % (status, body))
    status, body = space.login(TOKEN)
    check(status == 200 and body.get("role") == "operator", "the space's token logs in as operator: %s %s" % (status, body))
    operator_session = body["session"]
    status, body = space.login(VIEWER_TOKEN)
    check(status == 200 and body.get("role") == "viewer", "the viewer token logs in as viewer: %s %s" % (status, body))
    viewer_session = body["session"]
    # The CAMUS server's role decides: its client and SAM credentials log in, as viewers.
    status, body = space.login(CLIENT_TOKEN)
    check(status == 200 and body.get("role") == "viewer",
          "a credential the server gives the role client logs in as viewer: %s %s" % (status, body))
    client_session = body.get("session", "")
    status, body = space.login(SAM_TOKEN)
    check(status == 200 and body.get("role") == "viewer",
          "a credential the server gives the role sam logs in as viewer: %s %s" % (status, body))

    # No login, no connection (the gateway allows no anonymous role here); a foreign subprotocol neither.
    try:
        await websockets.connect(space.gateway_url, subprotocols=[SUBPROTOCOL])
        check(False, "a connection without a login is refused")
    except websockets.InvalidStatusCode as e:
        check(e.status_code == 401, "a connection without a login is refused with 401 (got %s)" % e.status_code)
    try:
        await websockets.connect(space.gateway_url + "?session=" + operator_session, subprotocols=["other"])
        check(False, "a connection without the Foxglove subprotocol is refused")
    except (websockets.InvalidStatusCode, websockets.InvalidHandshake):
        pass

    a = await Client.connect(space.gateway_url + "?session=" + operator_session)
    b = await Client.connect(space.gateway_url + "?session=" + viewer_session)
    check(a.ws.subprotocol == SUBPROTOCOL, "the server selects %s" % SUBPROTOCOL)
    await a.until("serverInfo and advertise", lambda: a.of("advertise"))
    first = a.ops[0]
    check(first.get("op") == "serverInfo", "the first message is serverInfo (got %s)" % first.get("op"))
    check({"services", "connectionGraph"} <= set(first.get("capabilities", [])), "capabilities: %s" % first.get("capabilities"))
    check(first.get("supportedEncodings") == ["json"], "supportedEncodings: %s" % first.get("supportedEncodings"))
    check(first.get("metadata", {}).get("role") == "operator", "metadata.role: %s" % first.get("metadata"))
    channels = a.channels()
    for topic in ("/graph", "/services", "/components", "/poses", "/trails", "/context", "/events", "/calls"):
        check(topic in channels, "channel %s advertised" % topic)
    for topic, channel in channels.items():
        check(channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema", "%s: json + jsonschema" % topic)
        schema = json.loads(channel["schema"])
        check(schema.get("type") == "object" and schema.get("title") == channel["schemaName"],
              "%s: schema is an object titled %s" % (topic, channel["schemaName"]))

    # Services: every operation of every service, CAMUS and RT, and lifecycle.
    rt_echo = "labpc.host_cxt/Diagnostic0.rtc:diagnostic/echo"
    wanted = ["diag/echo", "diag/fail", "diag/notify", "robot1.navigation/moveTo", "camus.tasks/Run",
              rt_echo, "labpc.host_cxt/Camera0.rtc/activate"]
    await a.until("services advertised: %s" % wanted, lambda: all(n in a.services() for n in wanted), 30)
    echo = a.services()["diag/echo"]
    check(echo["request"]["encoding"] == "json" and echo["request"]["schemaEncoding"] == "jsonschema",
          "diag/echo request: json + jsonschema")
    request_schema = json.loads(echo["request"]["schema"])
    check(request_schema["properties"]["text"]["type"] == "string", "diag/echo's request schema has text: string")
    check("requestSchema" not in echo and "responseSchema" not in echo,
          "the deprecated requestSchema / responseSchema are not sent: %s" % sorted(echo))

    # Subscribe: latched state first, then the stream; only to who asked.
    await a.send({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": channels["/poses"]["id"]},
                                                       {"id": 2, "channelId": channels["/services"]["id"]}]})
    await b.send({"op": "subscribe", "subscriptions": [{"id": 10, "channelId": channels["/poses"]["id"]}]})
    await a.until("poses on subscription 1", lambda: [d for d in a.data if d[0] == 1 and d[2]["robot"] == "robot1"])
    services = await a.until("the services snapshot",
                             lambda: [d for d in a.data if d[0] == 2 and
                                      any(s["name"] == "diag" for s in d[2]["services"])])
    catalog = services[-1][2]["services"]
    diag = [s for s in catalog if s["name"] == "diag"][0]
    check(diag["origin"] == "camus" and diag["seen_via"] == "camus" and "diag/echo" in diag["operations"],
          "diag: origin camus, callable: %s" % diag)
    bridged = [s for s in catalog if s["name"] == "camera"]
    check(bridged and bridged[0]["origin"].startswith("rtc:") and bridged[0]["bridge"] == "bridge-lab",
          "camera names its RT origin and bridge: %s" % bridged)
    check(any(s["seen_via"] == "naming" and s["name"] == "labpc.host_cxt/Camera0.rtc:imagerecognition" for s in catalog),
          "the camera's port is seen in the naming service")
    check(any(s["seen_via"] == "naming" and s["name"] == "labpc.host_cxt/camus_diag.rtc:diagnostic" and
              s["origin"] == "camus:diag" for s in catalog), "the RTC the bridge made for diag names its origin")
    pose = [d for d in a.data if d[0] == 1][-1]
    check(pose[2]["space"] == space.name and pose[2]["via"] == "devices", "a pose from the devices: %s" % (pose[2],))
    check(abs(pose[1] / 1e9 - pose[2]["stamp"]) < 1e-3, "the message's timestamp is the pose's stamp")
    check(not [d for d in b.data if d[0] != 10], "b gets only its own subscription")

    # Bad input from a: a Status each, a keeps its connection, b keeps receiving.
    b_before = len(b.data)
    statuses_before = len(a.statuses())
    await a.send("{this is not json")
    await a.send({"op": "takeOff"})
    await a.send({"op": "subscribe", "subscriptions": [{"id": 5, "channelId": 99999}]})
    await a.send({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": channels["/events"]["id"]}]})
    await a.send(bytes([0x07, 1, 2, 3]))
    await a.send(bytes([0x02, 1, 0]))
    await a.until("six statuses", lambda: len(a.statuses()) >= statuses_before + 6)
    got = a.statuses()[statuses_before:]
    check(all(s["level"] == 2 for s in got), "bad input gets error-level statuses: %s" % got)
    messages = [s["message"] for s in got]
    check(messages[0].startswith("not JSON"), "bad JSON: %s" % messages[0])
    check(messages[1] == "unknown op 'takeOff'", "unknown op: %s" % messages[1])
    check(messages[2] == "subscribe: unknown channel 99999", "unknown channel: %s" % messages[2])
    check(messages[3] == "subscribe: subscription id 1 is in use (unsubscribe it first)", "reused id: %s" % messages[3])
    check(messages[4] == "unknown binary opcode 7", "bad opcode: %s" % messages[4])
    check(messages[5] == "service call request: 3 bytes (at least 13)", "short call: %s" % messages[5])
    await b.until("b still receiving poses", lambda: len(b.data) > b_before + 3)
    a_poses = len([d for d in a.data if d[0] == 1])
    await a.until("a still receiving poses", lambda: len([d for d in a.data if d[0] == 1]) > a_poses + 3)

    # Unsubscribe: nothing more on that subscription once the server has read the request (a later
    # subscription's first message marks that point: messages to one client keep their order).
    await a.send({"op": "unsubscribe", "subscriptionIds": [1]})
    await a.send({"op": "subscribe", "subscriptions": [{"id": 3, "channelId": channels["/graph"]["id"]}]})
    await a.until("the graph on subscription 3", lambda: [d for d in a.data if d[0] == 3])
    mark = [i for i, d in enumerate(a.data) if d[0] == 3][0]
    await b.until("more poses to b", lambda: len(b.data) > b_before + 20)
    check(not [d for d in a.data[mark:] if d[0] == 1], "no pose on subscription 1 after unsubscribing")
    graph = [d for d in a.data if d[0] == 3][-1][2]
    check(graph["space"] == space.name and any(s["name"] == space.name and s["local"] for s in graph["spaces"]),
          "the graph names the local space: %s" % graph)

    # Service calls: replies, typed failures, events; refused to a viewer.
    await a.call("diag/echo", {"text": "hello gateway"}, 100)
    kind, answer = await a.answer(100)
    check(kind == "ok" and answer[2] == "json" and answer[3] == {"result": "hello gateway"},
          "diag/echo answers: %s %s" % (kind, answer))
    check(answer[0] == echo["id"], "the response names the service id")
    await a.call("diag/fail", {"reason": "on purpose", "code": 7}, 101)
    kind, answer = await a.answer(101)
    check(kind == "failure" and answer["message"].startswith("USER_EXCEPTION URS.Failure") and "on purpose" in
          answer["message"], "diag/fail gives the typed error: %s" % (answer,))
    await a.call("diag/echo", {"txt": 1}, 102)
    kind, answer = await a.answer(102)
    check(kind == "failure" and answer["message"].startswith("BAD_ARGUMENTS"), "bad arguments: %s" % (answer,))
    await a.call(rt_echo, {"text": "over CORBA"}, 103)
    kind, answer = await a.answer(103)
    check(kind == "ok" and answer[3] == {"result": "over CORBA"}, "the RT provider answers through DII: %s" % (answer,))
    await a.call(rt_echo.replace("/echo", "/fail"), {"reason": "typed over CORBA", "code": 5}, 106)
    kind, answer = await a.answer(106)
    check(kind == "failure" and answer["message"].startswith("USER_EXCEPTION URS.Failure") and
          '"typed over CORBA"' in answer["message"], "the RT provider's IDL exception arrives typed: %s" % (answer,))
    await b.call("diag/echo", {"text": "viewer"}, 104)
    kind, answer = await b.answer(104)
    check(kind == "failure" and answer["message"].startswith("PERMISSION_DENIED: diag/echo needs the operator role"),
          "a viewer may not call: %s" % (answer,))
    # A login whose credential the server gives the role client: it sees, and may not act (a call,
    # setting context, a component's lifecycle), each refused typed.
    c = await Client.connect(space.gateway_url + "?session=" + client_session)
    info = (await c.until("serverInfo", lambda: c.of("serverInfo")))[0]
    check(info.get("metadata", {}).get("role") == "viewer", "the client credential's metadata.role: %s" % info.get("metadata"))
    await c.until("the services", lambda: {"diag/echo", "camus.context/Set", rt_echo} <= set(c.services()))
    lifecycle = [name for name in c.services() if name.endswith("/activate")]
    check(lifecycle, "lifecycle operations advertised to a viewer too: %s" % sorted(c.services())[:20])
    for call_id, (name, request) in enumerate([("diag/echo", {"text": "client"}),
                                               ("camus.context/Set", {"key": "gw/test", "value": 1}),
                                               (lifecycle[0] if lifecycle else "none/activate", {})], 200):
        await c.call(name, request, call_id)
        kind, answer = await c.answer(call_id)
        check(kind == "failure" and answer["message"].startswith("PERMISSION_DENIED: %s needs the operator role" % name),
              "the client credential may not call %s: %s" % (name, answer))
    await c.ws.close()
    await a.send({"op": "subscribe", "subscriptions": [{"id": 4, "channelId": channels["/events"]["id"]}]})
    await a.call("diag/notify", {"topic": "gateway/test", "text": "an event"}, 105)
    await a.answer(105)
    event = await a.until("the notify event", lambda: [d for d in a.data if d[0] == 4 and d[2]["topic"] == "gateway/test"])
    check(json.loads(event[0][2]["payload"]).get("text") == "an event",
          "the event's payload is decoded, as JSON text: %s" % (event[0][2],))

    # Every call made through the gateway, answered, is on /calls with its reply and its caller.
    await a.send({"op": "subscribe", "subscriptions": [{"id": 6, "channelId": channels["/calls"]["id"]}]})
    # The recorded calls may come in several messages: wait for the two looked at below.
    def recorded_calls():
        calls = [d[2] for d in a.data if d[0] == 6]
        services = {c["service"] for c in calls}
        return calls if {"diag/echo", "diag/fail"} <= services else []
    calls = await a.until("the calls on /calls", recorded_calls)
    echoed = [c for c in calls if c["service"] == "diag/echo" and c["ok"]]
    check(echoed and json.loads(echoed[0]["request"]) == {"text": "hello gateway"} and
          json.loads(echoed[0]["reply"]) == {"result": "hello gateway"} and echoed[0]["role"] == "operator" and
          echoed[0]["type"] == "URS.Diagnostic.echo", "diag/echo is on /calls with its reply: %s" % echoed[:1])
    failed = [c for c in calls if c["service"] == "diag/fail"]
    check(failed and not failed[0]["ok"] and failed[0]["error"].startswith("USER_EXCEPTION"),
          "a failed call is on /calls with its error: %s" % failed[:1])

    # The connection graph.
    await a.send({"op": "subscribeConnectionGraph"})
    update = (await a.until("a connectionGraphUpdate", lambda: a.of("connectionGraphUpdate")))[0]
    names = {s["name"] for s in update["advertisedServices"]}
    check("%s/diag" % space.name in names and "%s/camera" % space.name in names,
          "the graph advertises the space's services: %s" % sorted(names)[:10])
    check(any(t["name"] == "/poses" for t in update["publishedTopics"]), "the graph lists the channels")
    check(not b.of("connectionGraphUpdate"), "b did not subscribe to the graph")

    # Logging out (the session as the login returned it, no cookie) ends the login's connections,
    # with a close frame saying why; the other login's connection goes on.
    status, out = post(space.http_url + "api/logout", {"session": operator_session})
    check(status == 200 and out == {"ended": True, "connections": 1}, "logout ends the session: %s %s" % (status, out))
    try:
        await asyncio.wait_for(a.task, 10)
    except asyncio.TimeoutError:
        pass
    check(a.ws.close_code == 1008 and a.ws.close_reason.startswith("logged out"),
          "the operator's connection is closed with a reason: %s %s" % (a.ws.close_code, a.ws.close_reason))
    b_count = len(b.data)
    await b.until("b still receiving after a's logout", lambda: len(b.data) > b_count + 3)
    await b.ws.close()


def run_checks(space, scenario, what, timeout):
    """Starts `space`, runs `scenario(space)` within `timeout` s and stops the space; on any failed
    check dumps the space's logs and exits 1 (the tests of this folder end so)."""
    with space:
        asyncio.run(asyncio.wait_for(scenario(space), timeout))
        if failures:
            space.dump_logs()
    if failures:
        print("%s: %d failure(s)" % (what, len(failures)))
        sys.exit(1)
    print("%s: every check passed" % what)


def main():
    build, source = sys.argv[1], sys.argv[2]
    run_checks(Space(build, source, "conf"), scenario, "conformance", 180)


if __name__ == "__main__":
    main()
