#!/usr/bin/python3
"""Calls the thermostat served by thermostat_agent.py: reads it, sets a target (watching the event
it publishes), tries a target out of range, nudges it (oneway).

  thermostat_client.py --server HOST:PORT --token-file client.token [--name thermo]"""
import argparse
import asyncio
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "python"))
import urslink  # noqa: E402


async def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--server", default=os.environ.get("URS_SERVER", "127.0.0.1:7400"))
    parser.add_argument("--token-file", required=True)
    parser.add_argument("--name", default="thermo")
    args = parser.parse_args()

    async with urslink.Client(args.server, token_file=args.token_file, peer_name="thermostat-client") as client:
        thermo = await client.proxy(args.name)        # the interface comes from the server (Describe)
        print("room:", (await thermo._get_room()).result)
        print("read:", (await thermo.read()).result)

        events = await client.subscribe("thermostat/%s/#" % args.name)
        reading = (await thermo.setTarget(celsius=21.5)).result
        print("setTarget(21.5):", reading.target)
        event = await events.get(timeout=10)
        print("event on %s from %s: %s" % (event.topic, event.source, event.content_type))

        try:
            await thermo.setTarget(celsius=99)
        except urslink.UserException as error:
            print("setTarget(99) raised %s %s" % (error.type_name, error.fields))

        await thermo.nudge(delta=0.5)                 # oneway: returns once sent
        event = await events.get(timeout=10)
        print("after nudge:", thermo.interface.message_class(event.content_type).FromString(event.payload).target)


if __name__ == "__main__":
    asyncio.run(main())
