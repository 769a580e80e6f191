#!/usr/bin/python3
"""Serves Demo.Thermostat (Thermostat.idl) on a CAMUS server as service NAME (default thermo).

  thermostat_agent.py --server HOST:PORT --token-file sam.token [--name thermo] [--room lab]

The token's credential needs role sam. Every change of the target is published as a
Demo.Reading event on thermostat/<NAME>/target. Stops on SIGTERM or SIGINT."""
import argparse
import asyncio
import logging
import os
import signal
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "python"))  # the SDK of this checkout, if not installed
import urslink  # noqa: E402

LOW, HIGH = 5.0, 30.0


class Thermostat(urslink.Agent):
    def __init__(self, interface, room):
        super().__init__(interface)
        self.room = room
        self.celsius = 19.0
        self.target = 20.0
        self.Reading = interface.message_class("Demo.Reading")

    def reading(self):
        return self.Reading(celsius=self.celsius, target=self.target, heating=self.celsius < self.target)

    def _get_room(self, request):
        return self.room                              # the reply's `result` field

    def read(self, request):
        return self.reading()

    async def setTarget(self, request):
        if not LOW <= request.celsius <= HIGH:
            raise self.interface.exception("OutOfRange", requested=request.celsius, min=LOW, max=HIGH)
        self.target = request.celsius
        await self.publish("thermostat/%s/target" % self.name, self.reading())
        return self.reading()

    async def nudge(self, request):                   # oneway: nothing goes back to the caller
        self.target = min(HIGH, max(LOW, self.target + request.delta))
        await self.publish("thermostat/%s/target" % self.name, self.reading())


async def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--server", default=os.environ.get("URS_SERVER", "127.0.0.1:7400"))
    parser.add_argument("--token-file", required=True)
    parser.add_argument("--name", default="thermo")
    parser.add_argument("--room", default="lab")
    parser.add_argument("--idl", default=os.path.join(HERE, "Thermostat.idl"))
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")

    interface = urslink.Interface.from_idl(args.idl)
    stop = asyncio.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        asyncio.get_running_loop().add_signal_handler(signum, stop.set)
    async with urslink.Client(args.server, token_file=args.token_file, role="sam",
                              peer_name="thermostat@python") as client:
        await client.serve(args.name, Thermostat(interface, args.room), deadline_ms=5000)
        print("serving %s (%s) on %s" % (args.name, interface.name, args.server), flush=True)
        await stop.wait()


if __name__ == "__main__":
    asyncio.run(main())
