"""Fleet bus throughput and latency through a real Mosquitto broker.

    python benchmarks/bench_bus.py                      # 64 UAVs, 10 Hz telemetry, 10 s, own broker
    python benchmarks/bench_bus.py --uavs 256 --hz 10 --seconds 10 --mqtt mqtt://HOST:1883

A FleetBus is fed a fresh sample for every UAV at --feed-hz, sends at --hz per UAV (and one event per UAV per
second); a plain aiomqtt subscriber on the same machine measures messages per second received and
end-to-end latency: event = raised -> received (QoS 1 path), telemetry = age of the sample when
received (includes the time it waited for the bus's next send tick, up to 1/feed-hz, since the
bus sends the newest sample). The broker runs with `set_tcp_nodelay true` (see docs/bus.md). Then
a saturation run: how many telemetry messages per second one FleetBus pushes through the broker
when asked for far more."""

from __future__ import annotations

import argparse
import asyncio
import getpass
import json
import multiprocessing
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import aiomqtt
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.bus import FleetBus, Telemetry, parse_broker_url


def start_mosquitto(folder: Path) -> tuple[subprocess.Popen, int]:
    exe = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    conf = folder / "mosquitto.conf"
    conf.write_text(f"listener {port} 127.0.0.1\nallow_anonymous true\nuser {getpass.getuser()}\n"
                    "max_queued_messages 1000000\nset_tcp_nodelay true\n")
    process = subprocess.Popen([exe, "-c", str(conf)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(200):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
            return process, port
        except OSError:
            time.sleep(0.02)
    raise RuntimeError("mosquitto did not start")


def subscriber_process(host: str, port: int, fleet: str, ready, stop, results) -> None:
    """A plain aiomqtt subscriber in its own process (so it does not share the publisher's CPU)."""
    async def run() -> None:
        tel, ev, counts = [], [], {"telemetry": 0, "event": 0, "state": 0}
        async with aiomqtt.Client(host, port) as sub:
            await sub.subscribe(f"gcs/{fleet}/uav/+/+", qos=1)
            ready.set()

            async def collect():
                async for message in sub.messages:
                    now = time.time()
                    kind = message.topic.value.rsplit("/", 1)[1]
                    counts[kind] += 1
                    if kind == "telemetry":
                        tel.append(now - json.loads(message.payload)["t_s"])
                    elif kind == "event":
                        ev.append(now - json.loads(message.payload)["t_s"])

            reader = asyncio.create_task(collect())
            while not stop.is_set():
                await asyncio.sleep(0.05)
            reader.cancel()
        results.put((counts, tel, ev))

    asyncio.run(run())


async def run_load(url: str, uavs: int, feed_hz: float, seconds: float, bus_hz: float, events: bool) -> dict:
    """Feed `uavs` samples at `feed_hz` (and one event per UAV per second) into a bus sending at `bus_hz`."""
    fleet = f"bench{time.time_ns()}"
    broker = parse_broker_url(url)
    ctx = multiprocessing.get_context("spawn")
    ready, stop, results = ctx.Event(), ctx.Event(), ctx.Queue()
    sub = ctx.Process(target=subscriber_process, args=(broker.host, broker.port, fleet, ready, stop, results))
    sub.start()
    await asyncio.get_running_loop().run_in_executor(None, ready.wait, 30)
    async with FleetBus(broker, fleet=fleet, station="bench", telemetry_hz=bus_hz) as bus:
        await bus.wait_connected(5)
        start = time.monotonic()
        tick = 0
        per_second = max(1, round(feed_hz))
        while time.monotonic() - start < seconds:
            now = time.time()
            for uid in range(1, uavs + 1):
                bus.telemetry(Telemetry(uid, "search", 45.0 + uid * 1e-4, 7.0, 30.0, 90.0, 80.0, 100.0, 10.0, t_s=now))
                if events and tick % per_second == uid % per_second:
                    bus.event(uid, "note", text=f"tick {tick}")
            tick += 1
            await asyncio.sleep(max(0.0, start + tick / feed_hz - time.monotonic()))
        elapsed = time.monotonic() - start
        await bus.drain(30)
        stats = bus.stats
    await asyncio.sleep(1.0)
    stop.set()
    counts, tel, ev = await asyncio.get_running_loop().run_in_executor(None, results.get, True, 60)
    sub.join(10)
    return {"elapsed": elapsed, "counts": counts, "tel_lat": np.array(tel) * 1e3, "ev_lat": np.array(ev) * 1e3,
            "stats": stats}


def report(title: str, r: dict) -> None:
    c, e = r["counts"], r["elapsed"]
    total = sum(c.values())
    print(f"{title}: {total / e:,.0f} msg/s received ({c['telemetry'] / e:,.0f} telemetry, "
          f"{c['event'] / e:,.0f} events, {c['state'] / e:,.0f} states) over {e:.1f} s; "
          f"dropped events {r['stats'].events_dropped}")
    for name, lat in (("event latency (raised -> received)", r["ev_lat"]),
                      ("telemetry sample age at receipt", r["tel_lat"])):
        if len(lat):
            print(f"  {name}: median {np.median(lat):.2f} ms, p99 {np.percentile(lat, 99):.2f} ms, "
                  f"max {lat.max():.2f} ms (n={len(lat)})")


async def main_async(args: argparse.Namespace, url: str) -> None:
    r = await run_load(url, args.uavs, args.feed_hz, args.seconds, args.hz, events=True)
    report(f"{args.uavs} UAVs at {args.hz:g} Hz telemetry (fed at {args.feed_hz:g} Hz) + 1 event/s each", r)
    expected = args.uavs * args.hz
    delivered = r["counts"]["telemetry"] / r["elapsed"] / expected
    print(f"  telemetry delivered {delivered:.1%} of the offered {expected:,.0f}/s")
    sat = await run_load(url, args.uavs, 200.0, min(args.seconds, 5.0), 200.0, events=False)
    offered = args.uavs * 200.0
    report(f"saturation: {args.uavs} UAVs fed and sent at 200 Hz ({offered:,.0f} telemetry/s offered)", sat)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--uavs", type=int, default=64)
    p.add_argument("--hz", type=float, default=10.0)
    p.add_argument("--feed-hz", type=float, default=20.0, help="how often the fleet layer hands the bus a sample")
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--mqtt", default=None, help="use this broker instead of starting a local Mosquitto")
    args = p.parse_args()
    process = None
    with tempfile.TemporaryDirectory() as folder:
        url = args.mqtt
        if url is None:
            process, port = start_mosquitto(Path(folder))
            url = f"mqtt://127.0.0.1:{port}"
        try:
            print(f"broker {url}; python {sys.version.split()[0]}, aiomqtt {aiomqtt.__version__}")
            asyncio.run(main_async(args, url))
        finally:
            if process is not None:
                process.terminate()
                process.wait(10)
    return 0


if __name__ == "__main__":
    sys.exit(main())
