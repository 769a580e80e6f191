#!/usr/bin/python3
"""The Python SDK's call latency: 64-byte diag.echo calls from urslink.Client through a real
urs-camus-server to the C++ diagnostic agent in urs-sam, measured as urs-bench measures its row
"Planet call client→server→SAM→SA | 64 B" (bench_stats.hpp: 500 warm-up calls, then 5 repetitions
of 2000; the median and p99 of all calls, the spread of the repetitions' medians; --quick: 20, 1 x 50).

  python_echo_bench.py --server HOST:PORT [--token-file F] [--quick] --json
      against a running space whose `diag` is the diagnostic agent: urs-bench runs it so, on its own
      space right after the C++ client's row, and prints the row next to it (deploy/bench.sh);
      prints {"median_us", "p99_us", "min_median_us", "max_median_us", "samples"}
  python_echo_bench.py --server-bin B --sam-bin B --cli-bin B [--quick]
      by hand: starts a space of its own (tests/python/run_sdk.py's) and prints one Markdown row."""
import argparse
import asyncio
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
from run_sdk import Space, urslink  # noqa: E402


def percentile(samples, p):
    """As urs::bench::percentile: the sample at rank p * (n - 1), rounded."""
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(p * (len(ordered) - 1) + 0.5))]


async def measure(server, token_file, warmup, iterations, repetitions):
    async with urslink.Client(server, token_file=token_file, peer_name="bench-python") as client:
        diag = await client.describe("diag")
        payload = diag.methods["echo"].request(text="x" * 64).SerializeToString()
        for _ in range(warmup):
            await client.call("diag", "echo", payload, deadline_ms=5000)
        samples, medians = [], []
        for _ in range(repetitions):
            run = []
            for _ in range(iterations):
                start = time.perf_counter()
                await client.call("diag", "echo", payload, deadline_ms=5000)
                run.append((time.perf_counter() - start) * 1e6)
            medians.append(percentile(run, 0.5))
            samples += run
        return {"median_us": percentile(samples, 0.5), "p99_us": percentile(samples, 0.99),
                "min_median_us": min(medians), "max_median_us": max(medians), "samples": len(samples)}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server", help="a running space's server (its diag is measured)")
    parser.add_argument("--token-file")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON, not a Markdown row")
    parser.add_argument("--server-bin")
    parser.add_argument("--sam-bin")
    parser.add_argument("--cli-bin")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    warmup, iterations, repetitions = (20, 50, 1) if args.quick else (500, 2000, 5)
    space = None
    if args.server:
        server, token_file = args.server, args.token_file
    else:
        if not (args.server_bin and args.sam_bin and args.cli_bin):
            parser.error("give --server, or --server-bin, --sam-bin and --cli-bin")
        args.keep = False
        space = Space(args)
        problem = space.up(agent=False)
        if problem:
            space.down()
            print(problem, "; see", space.work, file=sys.stderr)
            return 2
        server, token_file = space.server, space.tokens["client"]
    try:
        summary = asyncio.run(measure(server, token_file, warmup, iterations, repetitions))
    finally:
        if space:
            space.down()
    if args.json:
        print(json.dumps(summary))
    else:
        print("| Planet call, Python client (urslink)→server→SAM→SA | 64 B | %.1f µs | %.1f µs | %.1f µs – %.1f µs |"
              % (summary["median_us"], summary["p99_us"], summary["min_median_us"], summary["max_median_us"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
