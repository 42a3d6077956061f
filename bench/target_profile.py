#!/usr/bin/env python3
"""Where the firmware's instructions go: a profile of `bench-target` under
QEMU `-icount shift=0`, per function, per refining update.

Builds the firmware as `cargo xtask bench-target` does for the first
`--rows` rows of a record, runs it under QEMU with `-d
in_asm,exec,nochain` (every translated block with its instructions, every
execution of one), weighs each block by its executions and attributes it
to the symbol QEMU names (inlined code counts as its caller's). Blocks
are keyed by their translation (QEMU translates a hot loop again with
other bounds). The trace goes through a pipe, not a file (about 3 GB for
900 rows of a drive cycle).

Prints the instructions of each function per refining update (the count
`bench-target` reports), the share of the whole run, and with `--calls
NAME` the calls per refining update of the first function whose symbol
holds NAME (executions of its entry block); with `--lines N`, the N
source lines with the most instructions per refining update (each
instruction's executions mapped to its line, the innermost inlined frame,
by `arm-none-eabi-addr2line`; `--depth` names the functions it was
inlined into). The whole run includes the
paper method's start-up and the firmware's own work (stack painting,
logging), which `bench-target`'s per-update clock does not count.

    python3 bench/target_profile.py --model butler-volmer \\
        --input data/pybamm/chen2020-drive.csv --ocv data/pybamm/chen2020-ocv.csv \\
        --capacity-ah 5.153198 --rows 900 --calls arsinh

Needs qemu-system-arm, defmt-print and the thumbv7em-none-eabihf target,
as `cargo xtask bench-target` does; about a minute for 900 rows.
"""

import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile
import threading

ELF = "target/thumbv7em-none-eabihf/release/firmware"


def demangle(sym):
    """The readable path of a Rust legacy-mangled symbol (without hash)."""
    m = re.match(r"_ZN((?:\d+[^\d].*?)+)17h[0-9a-f]{16}E$", sym)
    if not m:
        return sym
    body, parts = m.group(1), []
    while body:
        n = re.match(r"\d+", body)
        if not n:
            break
        k = int(n.group(0))
        start = len(n.group(0))
        parts.append(body[start:start + k])
        body = body[start + k:]
    out = "::".join(parts)
    for a, b in (("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$C$", ","), ("..", "::"),
                 ("$u7b$", "{"), ("$u7d$", "}"), ("$RF$", "&")):
        out = out.replace(a, b)
    return out


def profile(trace):
    """(instructions per symbol, executions of each block's entry by
    symbol and guest address) from QEMU's in_asm/exec log."""
    blocks = {}
    runs = collections.Counter()
    pending = None
    sym, first, count, addrs = None, None, 0, []
    for line in trace:
        if line.startswith(b"Trace"):
            host = line.split()[2]
            if pending is not None:
                blocks[host] = pending
                pending = None
            runs[host] += 1
        elif line.startswith(b"IN:"):
            sym, first, count, addrs = line[3:].strip().decode(), None, 0, []
        elif line.startswith(b"0x"):
            pc = int(line[:10], 16)
            if first is None:
                first = pc
            count += 1
            addrs.append(pc)
            pending = (sym, first, count, addrs)
    per_symbol = collections.Counter()
    entries = collections.Counter()
    per_address = collections.Counter()
    for host, n in runs.items():
        if host in blocks:
            s, pc, k, addrs = blocks[host]
            per_symbol[s] += n * k
            entries[(s, pc)] += n
            for x in addrs:
                per_address[x] += n
    return per_symbol, entries, per_address


def print_lines(per_address, refining, top, depth=3):
    """The instructions per refining update of each source line, and the
    chain of functions it was inlined into (innermost first)."""
    addrs = sorted(per_address)
    per_line = collections.Counter()
    chains = {}
    batch = 2000
    for k in range(0, len(addrs), batch):
        part = addrs[k:k + batch]
        text = subprocess.run(["arm-none-eabi-addr2line", "-a", "-f", "-i", "-e", ELF]
                              + [hex(x) for x in part], capture_output=True,
                              text=True).stdout.splitlines()
        frames, cur = {}, None
        for line in text:
            if re.match(r"^0x[0-9a-f]+$", line):
                cur = int(line, 16)
                frames[cur] = []
            elif cur is not None:
                frames[cur].append(line)
        for x in part:
            f = frames.get(x, [])
            pairs = list(zip(f[0::2], f[1::2]))
            if not pairs:
                continue
            func, loc = pairs[0]
            loc = re.sub(r" \(discriminator \d+\)", "", loc)
            loc = re.sub(r"^.*/(estimator-core|firmware)/src/", r"\1/", loc)
            loc = re.sub(r"^.*/library/", "std/", loc)
            key = loc
            per_line[key] += per_address[x]
            chain = " < ".join(demangle(fn).split("::")[-1] for fn, _ in pairs[1:depth + 1])
            chains.setdefault(key, collections.Counter())[chain] += per_address[x]
    print(f"{'per refining update':>20}  source line (inlined into)")
    for key, n in per_line.most_common(top):
        chain = chains[key].most_common(1)[0][0]
        print(f"{n / refining:>20,.0f}  {key}  < {chain[:200]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--input", required=True, help="the record (CSV) bench-target replays")
    ap.add_argument("--rows", type=int, default=900, help="its first rows only (default 900)")
    ap.add_argument("--model", default="linear", choices=("linear", "butler-volmer"))
    ap.add_argument("--ocv")
    ap.add_argument("--capacity-ah")
    ap.add_argument("--top", type=int, default=16)
    ap.add_argument("--calls", metavar="NAME", help="also count the calls of this function")
    ap.add_argument("--lines", type=int, metavar="N",
                    help="also the N source lines (innermost inlined frame, by "
                         "arm-none-eabi-addr2line) with the most instructions per update")
    ap.add_argument("--depth", type=int, default=3,
                    help="with --lines, how many enclosing functions to name (default 3)")
    ap.add_argument("--out", default="target/profile")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    record = os.path.join(a.out, "input.csv")
    with open(a.input) as f, open(record, "w") as g:
        for k, line in enumerate(f):
            if k > a.rows:
                break
            g.write(line)
    cmd = ["cargo", "xtask", "bench-target", "--method", "refined", "--iterations", "1",
           "--model", a.model, "--input", record]
    if a.ocv:
        cmd += ["--ocv", a.ocv, "--capacity-ah", a.capacity_ah]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"bench-target failed:\n{run.stderr[-2000:]}")
    m = re.search(r"(\d+) updates ran the refinement", run.stderr + run.stdout)
    if not m:
        sys.exit("bench-target did not say how many updates refined")
    refining = int(m.group(1))
    median = re.search(r"median (\d+)", run.stderr + run.stdout)
    with tempfile.TemporaryDirectory() as d:
        fifo = os.path.join(d, "trace")
        os.mkfifo(fifo)
        result = {}

        def read():
            with open(fifo, "rb") as t:
                result["p"] = profile(t)

        reader = threading.Thread(target=read)
        reader.start()
        subprocess.run(["timeout", "1800", "qemu-system-arm", "-machine", "mps2-an386", "-cpu",
                        "cortex-m4", "-nographic", "-monitor", "none", "-serial", "none",
                        "-semihosting-config", "enable=on,target=native", "-icount", "shift=0",
                        "-d", "in_asm,exec,nochain", "-D", fifo, "-kernel", ELF],
                       stdout=subprocess.DEVNULL, check=True)
        reader.join()
    per_symbol, entries, per_address = result["p"]
    total = sum(per_symbol.values())
    print(f"{a.input}, first {a.rows} rows, {a.model}: {refining} refining updates, "
          f"bench-target median {median.group(1) if median else '?'} instructions per update")
    print(f"{'per refining update':>20}  {'share':>6}  function")
    for s, n in per_symbol.most_common(a.top):
        print(f"{n / refining:>20,.0f}  {100 * n / total:>5.1f}%  {demangle(s)[:110]}")
    if a.lines:
        print_lines(per_address, refining, a.lines, a.depth)
    if a.calls:
        hits = {(s, pc): n for (s, pc), n in entries.items() if a.calls in s}
        if not hits:
            sys.exit(f"no function holds {a.calls!r}")
        name = min(hits, key=lambda k: k[1])[0]
        entry = min(pc for (s, pc) in hits if s == name)
        print(f"{demangle(name)}: {hits[(name, entry)] / refining:,.1f} calls per refining update")


if __name__ == "__main__":
    main()
