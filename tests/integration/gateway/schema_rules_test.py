#!/usr/bin/env python3
"""Every channel and every service of a space running all devices — robot, localizer, camera,
TTS, voice recognition, the diagnostic agent, the example C++ plug-in's calculator and the Python
SDK example's thermostat, RT-Components through the bridge, the server's context and tasks —
keeps the schema rules of Foxglove and Lichtblick (foxglove_rules.py, docs/dashboard.md "Schema
rules"), and what each carries validates against its schema (JSON Schema 2020-12, python3-jsonschema):
messages of every channel that published during the run, and the replies of calls made.

    schema_rules_test.py BUILD_DIR SOURCE_DIR
"""
import json
import sys

import jsonschema

from conformance_test import Client, check, run_checks
from foxglove_rules import channel_problems, service_problems
from space import Space, TOKEN


def validate(value, schema_text, where):
    try:
        jsonschema.Draft202012Validator(json.loads(schema_text)).validate(value)
    except jsonschema.ValidationError as e:
        check(False, "%s does not validate against its schema: %s at %s" % (where, e.message, list(e.absolute_path)))


async def scenario(space):
    status, body = space.login(TOKEN)
    assert status == 200, body
    client = await Client.connect(space.gateway_url + "?session=" + body["session"])
    robot_topic = "/%s/robot1/pose" % space.name
    wanted_services = ["diag/echo", "robot1.navigation/moveTo", "robot1.localizer/getPose", "camera1/captureImage",
                       "tts1/speak", "voice1/cancelAll", "calc/divide", "thermo/setTarget", "camus.context/Set",
                       "camus.tasks/Run", "labpc.host_cxt/Diagnostic0.rtc:diagnostic/echo",
                       "labpc.host_cxt/Camera0.rtc/activate"]
    await client.until("every device's services: %s" % wanted_services,
                       lambda: all(name in client.services() for name in wanted_services), 60)
    await client.until("the robot's own channel", lambda: robot_topic in client.channels(), 30)
    channels, services = client.channels(), client.services()
    print("checking %d channels and %d services" % (len(channels), len(services)), flush=True)
    broken = []
    for channel in channels.values():
        broken += channel_problems(channel)
    for service in services.values():
        broken += service_problems(service)
    for problem in broken:
        print("RULE:", problem)
    check(not broken, "%d rule(s) broken over %d channels and %d services" % (len(broken), len(channels), len(services)))

    # The per-robot channel is in the connection graph.
    await client.send({"op": "subscribeConnectionGraph"})
    update = (await client.until("the connection graph", lambda: client.of("connectionGraphUpdate")))[0]
    check(any(t["name"] == robot_topic for t in update["publishedTopics"]),
          "%s is in the connection graph's published topics" % robot_topic)

    # What arrives validates: every channel subscribed; a context entry and an event made to arrive.
    by_subscription = {}
    for number, (topic, channel) in enumerate(sorted(channels.items()), 1):
        by_subscription[number] = channel
    await client.send({"op": "subscribe", "subscriptions": [{"id": n, "channelId": c["id"]}
                                                            for n, c in by_subscription.items()]})
    calls = [("camus.context/Set", {"key": "rules/probe", "value": json.dumps({"on": True, "level": 3})}),
             ("diag/notify", {"topic": "rules/probe", "text": "an event"}),
             ("thermo/setTarget", {"celsius": 21.5}), ("calc/divide", {"dividend": 7, "divisor": 2}),
             ("robot1.localizer/getPose", {}), ("camus.context/Get", {"key": "rules/probe"}),
             ("labpc.host_cxt/Diagnostic0.rtc:diagnostic/echo", {"text": "rt"})]
    for call_id, (name, request) in enumerate(calls, 1):
        await client.call(name, request, call_id)
        kind, answer = await client.answer(call_id)
        if check(kind == "ok", "%s answers: %s" % (name, answer)):
            validate(answer[3], services[name]["response"]["schema"], "the reply of %s" % name)
            if name == "camus.context/Get":
                check(json.loads(answer[3]["value"]) == {"on": True, "level": 3},
                      "a Value comes back as the JSON text of what was set: %s" % answer[3])
    topics = {c["topic"] for c in by_subscription.values()}
    await client.until("messages on /context, /events, /poses and %s" % robot_topic, lambda: {
        "/context", "/events", "/poses", robot_topic} <= {by_subscription[d[0]]["topic"] for d in client.data}, 30)
    seen = set()
    for subscription, stamp, message in client.data:
        channel = by_subscription[subscription]
        seen.add(channel["topic"])
        validate(message, channel["schema"], "a message on %s" % channel["topic"])
    print("validated messages of %s (of %d channels)" % (sorted(seen), len(topics)), flush=True)
    entry = [d[2] for d in client.data if by_subscription[d[0]]["topic"] == "/context" and d[2]["key"] == "rules/probe"]
    check(entry and isinstance(entry[-1]["value"], str) and json.loads(entry[-1]["value"]) == {"on": True, "level": 3},
          "/context carries the value as its JSON text: %s" % entry[-1:])
    await client.ws.close()


def main():
    build, source = sys.argv[1], sys.argv[2]
    run_checks(Space(build, source, "rules", all_devices=True), scenario, "schema rules", 240)


if __name__ == "__main__":
    main()
