#!/usr/bin/python3
"""The SDK's two agents called from another space, over the DDS link of two urs-bridge:

  space sdka: urs-camus-server, urs-sam hosting the example C++ plug-in (calc, PluginExample.Calculator,
              loaded from `plugins:`), the example's Python agent (thermo, Demo.Thermostat), bridge-a
  space sdkb: urs-camus-server, omniNames and bridge-b (--server and --naming) importing sdka's
              services as CAMUS services (sdkb sees sdka/calc, sdka/thermo) and as RTCs
              (<host>.host_cxt/sdka_calc.rtc, sdka_thermo.rtc), each described by the catalog

Checks, all from space sdkb: `urs call` on both (results, an attribute, a oneway, the declared
exceptions with their fields), the Python client on both (proxies built from the description that
crossed the link), and an RT consumer (`urs rtc call`, a CORBA dynamic invocation with the
example's IDL) on both RTCs. Both bridges link in a DDS domain reserved for this run.

  run_sdk_federation.py --server-bin B --sam-bin B --cli-bin B --bridge-bin B --plugin-dir D
                        --calculator-idl F [--keep]
Prints PASS/FAIL per check; exit status 1 if one failed, 2 if the spaces did not start."""
import argparse
import json
import os
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import run_sdk  # noqa: E402  (its Space, expect and wait_for; it puts python/ on the path)
from run_sdk import EXAMPLE, Failed, Space, expect, free_port, run_suite, urslink, wait_for  # noqa: E402

sys.path.insert(0, os.path.join(run_sdk.ROOT, "tests", "support"))
from dds_domain import lock_dds_domain  # noqa: E402  (the lock every test linking spaces takes)

A, B = "sdka", "sdkb"
RT_HOST = "bhost"


class Federation:
    """Space A (calc + thermo) and space B (server, omniNames), each with its bridge on one domain."""

    def __init__(self, args):
        self.args = args
        self.domain, self.domain_lock = lock_dds_domain()
        self.a = Space(args, A, "plugins: [%s]\nagents:\n  - {name: calc, type: calculator, params: {label: %s-calc}}\n"
                       % (os.path.join(args.plugin_dir, "libtest_calculator_plugin.so"), A))
        self.b = Space(args, B)
        self.naming = None

    def bridge_config(self, space, name):
        with open(space.path("bridge.yaml"), "w") as f:
            f.write("name: %s\ndds:\n  domain: %d\n  lease_ms: 2000\n  udp_only: true\n"
                    "  import: {deadline_ms: 10000}\n" % (name, self.domain))
        return space.path("bridge.yaml")

    def start_bridge(self, space, name, *extra):
        space.start("bridge", [self.args.bridge_bin, "--space", space.name, "--server", space.server,
                               "--config", self.bridge_config(space, name), "--token-file", space.tokens["operator"],
                               "--ready-file", space.path("bridge.ready"), "--log-level", "info"] + list(extra))
        if not wait_for(lambda: os.path.exists(space.path("bridge.ready")), 30):
            return "%s did not come up" % name
        return None

    def up(self):
        problem = self.a.up(sam_service="calc")
        if problem:
            return "space %s: %s" % (A, problem)
        self.b.start_server()
        if not wait_for(lambda: "listening on" in self.b.log("server"), 20):
            return "space %s: the server did not start" % B
        naming_port = free_port()
        self.naming = "127.0.0.1:%d" % naming_port
        os.makedirs(self.b.path("naming"), exist_ok=True)
        self.b.start("omniNames", ["omniNames", "-start", str(naming_port), "-datadir", self.b.path("naming"),
                                   "-logdir", self.b.path("naming"), "-ORBendPoint", "giop:tcp:" + self.naming])
        if not wait_for(lambda: "Root context is" in self.b.log("omniNames"), 20):
            return "omniNames did not start"
        return (self.start_bridge(self.a, "bridge-a")
                or self.start_bridge(self.b, "bridge-b", "--naming", self.naming, "--host", RT_HOST))

    def down(self):
        self.b.down()
        self.a.down()
        self.domain_lock.close()

    def rtc(self, *argv):
        return run_sdk.cli([self.args.cli_bin, "rtc", "--naming", self.naming] + list(argv))


def reply_of(run):
    expect(run.returncode == 0, "the call succeeds", run.stdout)
    return json.loads(run.stdout)["result"]


# ---- checks ------------------------------------------------------------------------------------

def check_imported(fed):
    """B lists A's two agents as CAMUS services, with their interfaces and the link as origin."""
    def listed():
        out = fed.b.urs("ls", A + "/*").stdout
        return ("%s/calc " % A) in out and ("%s/thermo " % A) in out
    expect(wait_for(listed, 40), "%s/calc and %s/thermo are services in %s" % (A, A, B), fed.b.urs("ls").stdout)
    out = fed.b.urs("ls", A + "/*").stdout
    for service, interface in (("calc", "PluginExample.Calculator"), ("thermo", "Demo.Thermostat")):
        line = [row for row in out.splitlines() if row.startswith("%s/%s " % (A, service))]
        expect(line and interface in line[0] and "dds:%s/%s" % (A, service) in line[0],
               "%s/%s is %s, imported over DDS" % (A, service, interface), out)


def check_urs_call_plugin(fed):
    """`urs call` in B on A's C++ plug-in: a result, its params, DivisionByZero with its field."""
    expect(reply_of(fed.b.urs("call", A + "/calc", "divide", '{"dividend": 7, "divisor": 2}')) == 3.5,
           "7 / 2 from the other space")
    expect(reply_of(fed.b.urs("call", A + "/calc", "label")) == A + "-calc", "the plug-in's params")
    run = fed.b.urs("call", A + "/calc", "divide", '{"dividend": 1, "divisor": 0}')
    expect(run.returncode == 1 and "USER_EXCEPTION" in run.stdout and "PluginExample.DivisionByZero" in run.stdout
           and '"dividend":1' in run.stdout.replace(" ", ""),
           "DivisionByZero, with its dividend, travels back to the other space", run.stdout)


def check_urs_call_python(fed):
    """`urs call` in B on A's Python agent: an attribute, a result, a oneway, OutOfRange's fields."""
    expect(reply_of(fed.b.urs("call", A + "/thermo", "_get_room")) == "kitchen", "the attribute room")
    expect(reply_of(fed.b.urs("call", A + "/thermo", "setTarget", '{"celsius": 22.5}'))["target"] == 22.5,
           "setTarget from the other space")
    run = fed.b.urs("call", A + "/thermo", "nudge", '{"delta": 1}')
    expect(run.returncode == 0, "a oneway from the other space", run.stdout)
    read = lambda: fed.a.urs("call", "thermo", "read").stdout  # noqa: E731
    expect(wait_for(lambda: '"target":23.5' in read().replace(" ", ""), 10), "the oneway reached the Python agent",
           read())
    run = fed.b.urs("call", A + "/thermo", "setTarget", '{"celsius": 99}')
    expect(run.returncode == 1 and "USER_EXCEPTION" in run.stdout and "Demo.OutOfRange" in run.stdout
           and '"requested":99' in run.stdout.replace(" ", ""),
           "Demo.OutOfRange, with its fields, travels back to the other space", run.stdout)


async def check_python_client(fed):
    """The Python client in B calls both through proxies built from the descriptions B's registry
    got over the link (no IDL file on B's side)."""
    async with urslink.Client(fed.b.server, token_file=fed.b.tokens["client"], peer_name="sdkb-client") as client:
        calc = await client.proxy(A + "/calc")
        expect(calc.interface.name == "PluginExample.Calculator", "described as PluginExample.Calculator",
               calc.interface.name)
        expect((await calc.divide(dividend=9, divisor=4)).result == 2.25, "divide")
        try:
            await calc.divide(dividend=5, divisor=0)
            raise Failed("a division by zero returned")
        except urslink.UserException as error:
            expect(error.type_name == "PluginExample.DivisionByZero" and error.fields == {"dividend": 5.0},
                   "DivisionByZero raised with its field", (error.type_name, error.fields))
        thermo = await client.proxy(A + "/thermo")
        expect(thermo.interface.name == "Demo.Thermostat", "described as Demo.Thermostat", thermo.interface.name)
        expect((await thermo.setTarget(celsius=18)).result.target == 18, "setTarget")
        try:
            await thermo.setTarget(celsius=-3)
            raise Failed("an out-of-range target was accepted")
        except urslink.UserException as error:
            expect(error.type_name == "Demo.OutOfRange" and error.fields == {"requested": -3.0, "min": 5.0, "max": 30.0},
                   "OutOfRange raised with its fields", (error.type_name, error.fields))


def check_rt_consumer(fed):
    """An RT consumer in B (urs rtc call, CORBA) on the RTCs bridge-b made of A's two agents."""
    calc = "%s.host_cxt/%s_calc.rtc:calculator" % (RT_HOST, A)
    thermo = "%s.host_cxt/%s_thermo.rtc:thermostat" % (RT_HOST, A)
    calc_idl, thermo_idl = fed.args.calculator_idl, os.path.join(EXAMPLE, "Thermostat.idl")
    expect(wait_for(lambda: fed.rtc("call", calc, "calls", "--idl", calc_idl).returncode == 0, 40),
           "bridge-b offers %s/calc as an RTC" % A, fed.rtc("call", calc, "calls", "--idl", calc_idl).stdout)
    run = fed.rtc("call", calc, "divide", '{"dividend": 5, "divisor": 4}', "--idl", calc_idl)
    expect(run.returncode == 0 and json.loads(run.stdout) == {"result": 1.25}, "divide through both bridges",
           run.stdout)
    run = fed.rtc("call", calc, "divide", '{"dividend": 2, "divisor": 0}', "--idl", calc_idl)
    expect(run.returncode == 1 and "USER_EXCEPTION PluginExample.DivisionByZero" in run.stdout,
           "DivisionByZero reaches the RT consumer as a CORBA user exception", run.stdout)
    expect(wait_for(lambda: fed.rtc("call", thermo, "_get_room", "--idl", thermo_idl).returncode == 0, 40),
           "bridge-b offers %s/thermo as an RTC" % A, fed.rtc("call", thermo, "_get_room", "--idl", thermo_idl).stdout)
    run = fed.rtc("call", thermo, "_get_room", "--idl", thermo_idl)
    expect(json.loads(run.stdout) == {"result": "kitchen"}, "the attribute through both bridges", run.stdout)
    run = fed.rtc("call", thermo, "setTarget", '{"celsius": 24.5}', "--idl", thermo_idl)
    expect(run.returncode == 0 and json.loads(run.stdout)["result"]["target"] == 24.5,
           "setTarget through both bridges", run.stdout)
    run = fed.rtc("call", thermo, "setTarget", '{"celsius": -40}', "--idl", thermo_idl)
    expect(run.returncode == 1 and "Demo.OutOfRange" in run.stdout and "-40" in run.stdout,
           "OutOfRange reaches the RT consumer with its fields", run.stdout)


CHECKS = [("federation_imported", check_imported), ("federation_urs_call_plugin", check_urs_call_plugin),
          ("federation_urs_call_python", check_urs_call_python),
          ("federation_python_client", check_python_client), ("federation_rt_consumer", check_rt_consumer)]


def main():
    parser = argparse.ArgumentParser()
    for option in ("--server-bin", "--sam-bin", "--cli-bin", "--bridge-bin", "--plugin-dir", "--calculator-idl"):
        parser.add_argument(option, required=True)
    parser.add_argument("--keep", action="store_true")
    args = parser.parse_args()
    if not shutil.which("omniNames"):
        print("SETUP FAILED: omniNames (Debian: omniorb-nameserver) is not installed")
        return 2
    os.environ.setdefault("URS_OMNIIDL_BACKEND_DIR", os.path.join(run_sdk.ROOT, "idl", "omniidl_planet"))
    fed = Federation(args)

    def clean_up(failures):
        for space in (fed.a, fed.b):
            space.clean_up(failures, args.keep, ("server", "sam", "agent", "bridge", "omniNames"))
    return run_suite(fed, CHECKS, "", clean_up)


if __name__ == "__main__":
    sys.exit(main())
