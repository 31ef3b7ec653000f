"""Soak test of live forecasting: many steps of a 100-pedestrian scene through ``stream()``.

Usage:
    python benchmarks/soak.py [--steps 100000] [--people 100] [--checkpoint NAME_OR_PATH]
                              [--forecast ml-argmax|ml|ml-top10|ml-topK] [--threads 2]
                              [--report-every 10000] [--out soak.json]

Pedestrians walk through a square sized for one person per 4 m^2; whoever leaves it is
replaced by a newcomer with a new id entering from the edge (so ids keep growing and agents
appear and vanish), and 1% of detections are dropped at random (missed detections split
tracks unless filled). Every ``--report-every`` steps it prints the latency percentiles of
that block, the coverage (of the people detected at a step and seen before, the fraction with
a forecast: the worst step and the mean) and the process's resident memory; at the end, the
whole run's percentiles and the memory at the start (after the first block) and at the end.
Memory that keeps growing would show as a rising RSS column.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
from streaming import add_predictor_options, load_predictor  # benchmarks/ is on sys.path

DT_S = 0.4


def resident_mb() -> float:
    """Current resident set size in MB (peak RSS where /proc is not available)."""
    statm = Path("/proc/self/statm")
    if statm.exists():
        pages = int(statm.read_text().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 1e6
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 1e6 if sys.platform == "darwin" else peak / 1e3


class Crowd:
    """``people`` pedestrians walking through a square; leavers are replaced by newcomers."""

    def __init__(self, people: int, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)
        self.side = 2.0 * np.sqrt(people)
        self.pos = self.rng.uniform(0, self.side, (people, 2))
        self.vel = self._velocities(self.pos)
        self.ids = np.arange(people)
        self.next_id = people

    def _velocities(self, pos: np.ndarray) -> np.ndarray:
        """Walking speeds of 0.8-1.6 m/s, headed roughly through the square's centre."""
        to_centre = self.side / 2 - pos
        heading = np.arctan2(to_centre[:, 1], to_centre[:, 0])
        heading = heading + self.rng.normal(0, 0.6, len(pos))
        speed = self.rng.uniform(0.8, 1.6, len(pos))
        return speed[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1)

    def step(self) -> tuple[np.ndarray, np.ndarray]:
        """Advance 0.4 s; return the (M,) ids and (M, 2) positions detected this step."""
        self.vel += self.rng.normal(0, 0.05, self.vel.shape)
        self.pos += self.vel * DT_S
        gone = ((self.pos < 0) | (self.pos > self.side)).any(axis=1)
        if gone.any():
            count = int(gone.sum())
            edge = self.rng.integers(0, 4, count)
            along = self.rng.uniform(0, self.side, count)
            fresh = np.stack([along, along], 1)
            fresh[edge == 0, 0], fresh[edge == 1, 0] = 0.0, self.side
            fresh[edge == 2, 1], fresh[edge == 3, 1] = 0.0, self.side
            self.pos[gone] = fresh
            self.vel[gone] = self._velocities(fresh)
            self.ids[gone] = self.next_id + np.arange(count)
            self.next_id += count
        seen = self.rng.random(len(self.ids)) >= 0.01
        return self.ids[seen].copy(), self.pos[seen].copy()


def percentiles(times_ms: np.ndarray) -> dict[str, float]:
    return {f"p{q}": float(np.percentile(times_ms, q)) for q in (50, 90, 99, 100)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_predictor_options(parser, forecast=None)
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--people", type=int, default=100)
    parser.add_argument("--report-every", type=int, default=10_000)
    parser.add_argument("--out", help="JSON file for the block and total figures")
    args = parser.parse_args()
    predictor = load_predictor(args)
    print(
        f"{predictor.source}: {args.people} people, {args.steps} steps, "
        f"point forecast {predictor.point_forecast_name}, {args.threads} threads",
        flush=True,
    )
    print(
        f"{'steps':>8} {'p50 ms':>7} {'p90 ms':>7} {'p99 ms':>7} {'max ms':>7} "
        f"{'RSS MB':>7} {'window rows':>11} {'ids so far':>10} {'coverage min/mean':>18}",
        flush=True,
    )
    crowd, session = Crowd(args.people), predictor.stream()
    times, coverage = np.zeros(args.steps), np.ones(args.steps)
    blocks, forecasts, seen_before = [], 0, set()
    started = time.perf_counter()
    for k in range(args.steps):
        ids, xy = crowd.step()
        tick = time.perf_counter()
        forecast = session.update(10 * k, ids, xy)
        times[k] = 1000 * (time.perf_counter() - tick)
        forecasts += len(forecast)
        detected = set(ids.tolist())
        eligible = detected & seen_before  # people in view with 2 or more points
        if eligible:
            coverage[k] = len(eligible & set(forecast.ids.tolist())) / len(eligible)
        seen_before |= detected
        if (k + 1) % args.report_every == 0 or k + 1 == args.steps:
            block = slice(max(0, k + 1 - args.report_every), k + 1)
            row = {
                "steps": k + 1,
                **percentiles(times[block]),
                "coverage_min": float(coverage[block].min()),
                "coverage_mean": float(coverage[block].mean()),
                "rss_mb": resident_mb(),
                "window_rows": len(session._rows),
                "ids": crowd.next_id,
            }
            blocks.append(row)
            print(
                f"{row['steps']:>8} {row['p50']:>7.1f} {row['p90']:>7.1f} {row['p99']:>7.1f} "
                f"{row['p100']:>7.1f} {row['rss_mb']:>7.0f} {row['window_rows']:>11} "
                f"{row['ids']:>10} {row['coverage_min']:>8.3f} / {row['coverage_mean']:.4f}",
                flush=True,
            )
    total = {
        **percentiles(times),
        "wall_minutes": (time.perf_counter() - started) / 60,
        "forecasts": forecasts,
        "coverage_min": float(coverage.min()),
        "coverage_mean": float(coverage.mean()),
        "rss_start_mb": blocks[0]["rss_mb"],
        "rss_end_mb": blocks[-1]["rss_mb"],
    }
    print(json.dumps(total, indent=1))
    if args.out:
        Path(args.out).write_text(
            json.dumps({"args": vars(args), "blocks": blocks, "total": total}, indent=1)
        )


if __name__ == "__main__":
    main()
