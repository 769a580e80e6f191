#!/usr/bin/python3
"""The Python SDK's call latency: 64-byte diag.echo calls from urslink.Client through a real
urs-camus-server to the C++ diagnostic agent in urs-sam, measured as urs-bench measures its row
"Planet call client→server→SAM→SA | 64 B" (500 warm-up calls, then 5 repetitions of 2000; the
median and p99 of all calls, the spread of the repetitions' medians).

  python_echo_bench.py --server-bin B --sam-bin B --cli-bin B [--quick]
Prints one Markdown row. Not a test: run it by hand (docs/sdk.md), next to urs-bench."""
import argparse
import asyncio
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
from run_sdk import Space, urslink  # noqa: E402


async def measure(space, warmup, iterations, repetitions):
    async with urslink.Client(space.server, token_file=space.tokens["client"], peer_name="bench") as client:
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
            medians.append(statistics.median(run))
            samples += run
        samples.sort()
        return statistics.median(samples), samples[int(len(samples) * 0.99) - 1], min(medians), max(medians)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--sam-bin", required=True)
    parser.add_argument("--cli-bin", required=True)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    args.keep = False
    space = Space(args)
    try:
        problem = space.up(agent=False)
        if problem:
            print(problem, "; see", space.work)
            return 2
        warmup, iterations, repetitions = (20, 50, 1) if args.quick else (500, 2000, 5)
        median, p99, low, high = asyncio.run(measure(space, warmup, iterations, repetitions))
        print("| Planet call, Python client (urslink)→server→SAM→SA | 64 B | %.0f µs | %.0f µs | %.0f µs – %.0f µs |"
              % (median, p99, low, high))
        return 0
    finally:
        space.down()


if __name__ == "__main__":
    sys.exit(main())
