#!/usr/bin/env python3
"""`bench shear` of several builds, run alternately, with the CPU other programs used
during each run (the machine may be shared: a two-thread figure means little when
another program holds a core). One JSON line per run and size.

    python3 bench/alternate_shear.py --rounds 3 --out runs.jsonl \\
        target-a/release/pillar-pipe target-b/release/pillar-pipe \\
        -- bench shear --n 16384,65536 --steps 1000 --warmup 500 --json

`others` is the average number of cores busy with other work during the run (busy time
from /proc/stat less this run's own CPU time, over its wall time).
"""
import argparse, json, os, resource, subprocess, sys, time


def cpu_busy():
    """(total, idle) jiffies of the machine so far."""
    v = list(map(int, open("/proc/stat").readline().split()[1:9]))
    return sum(v), v[3] + v[4]


def main():
    argv = sys.argv[1:]
    cut = argv.index("--")
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out")
    ap.add_argument("bins", nargs="+")
    a = ap.parse_args(argv[:cut])
    args = argv[cut + 1:]
    hz = os.sysconf("SC_CLK_TCK")
    for r in range(a.rounds):
        for b in a.bins:
            t0, i0 = cpu_busy()
            u0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            w0 = time.time()
            p = subprocess.run([b] + args, capture_output=True, text=True, check=True)
            t1, i1 = cpu_busy()
            u1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            wall = time.time() - w0
            busy = (t1 - t0 - (i1 - i0)) / hz
            ours = (u1.ru_utime + u1.ru_stime) - (u0.ru_utime + u0.ru_stime)
            for line in p.stdout.splitlines():
                d = json.loads(line)
                rec = dict(
                    bin=b, round=r, others=round(max(0.0, busy - ours) / wall, 3), n=d["n"],
                    one=round(d["ns_per_particle_step_one_thread"], 2),
                    two=round(d["ns_per_particle_step_two_threads"], 2),
                    speedup=round(d["two_thread_speedup"], 3),
                    solo=d.get("two_thread_solo_steps"),
                    load=open("/proc/loadavg").read().split()[0],
                )
                print(json.dumps(rec), flush=True)
                if a.out:
                    with open(a.out, "a") as f:
                        f.write(json.dumps(rec) + "\n")


if __name__ == "__main__":
    main()
