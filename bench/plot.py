#!/usr/bin/env python3
"""Log-log plot (SVG) of the host time per iteration against the window L
(at M = 64) and against the memory M (at L = 4000), with fitted slopes,
from criterion's results (run `cargo bench -p estimator-core --bench
iteration` first). No plotting library needed.

    python3 bench/plot.py [--criterion target/criterion] [--out docs/performance/cost.svg]

Prints a Markdown table of the medians and the fitted slopes.
"""
import argparse
import json
import math
import os
import sys

GROUPS = ["op_gi", "kt_gi", "battery_paper", "battery_refined"]
COLORS = {"op_gi": "#1f77b4", "kt_gi": "#ff7f0e", "battery_paper": "#2ca02c", "battery_refined": "#d62728"}


def median_ns(root, group, ty, l, m):
    p = os.path.join(root, f"{group}_{ty}", f"L{l}", str(m), "new", "estimates.json")
    try:
        with open(p) as f:
            return json.load(f)["median"]["point_estimate"]
    except OSError:
        return None


def slope(points):
    xs = [math.log(x) for x, _ in points]
    ys = [math.log(y) for _, y in points]
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else float("nan")


def panel(x0, title, xlabel, series, xr, yr):
    W, H, L, B = 420, 300, 60, 40
    out = [f'<g transform="translate({x0},0)">',
           f'<text x="{L + (W - L) / 2}" y="20" text-anchor="middle" font-size="14">{title}</text>']
    lx = lambda x: L + (math.log10(x) - xr[0]) / (xr[1] - xr[0]) * (W - L - 10)
    ly = lambda y: H - B - (math.log10(y) - yr[0]) / (yr[1] - yr[0]) * (H - B - 35)
    out.append(f'<rect x="{L}" y="35" width="{W - L - 10}" height="{H - B - 35}" fill="none" stroke="#888"/>')
    for d in range(math.floor(xr[0]), math.ceil(xr[1]) + 1):
        for k in (1, 2, 5):
            v = k * 10 ** d
            if xr[0] <= math.log10(v) <= xr[1]:
                out.append(f'<text x="{lx(v)}" y="{H - B + 15}" text-anchor="middle" font-size="10">{v:g}</text>')
    for d in range(math.floor(yr[0]), math.ceil(yr[1]) + 1):
        v = 10 ** d
        if yr[0] <= d <= yr[1]:
            lab = f"{v * 1e-3:g} µs" if v < 1e6 else f"{v * 1e-6:g} ms"
            out.append(f'<line x1="{L}" x2="{W - 10}" y1="{ly(v)}" y2="{ly(v)}" stroke="#eee"/>')
            out.append(f'<text x="{L - 4}" y="{ly(v) + 3}" text-anchor="end" font-size="10">{lab}</text>')
    out.append(f'<text x="{L + (W - L) / 2}" y="{H - 5}" text-anchor="middle" font-size="12">{xlabel}</text>')
    for i, (name, pts, k) in enumerate(series):
        c = COLORS[name]
        path = " ".join(f"{lx(x):.1f},{ly(y):.1f}" for x, y in pts)
        out.append(f'<polyline points="{path}" fill="none" stroke="{c}" stroke-width="2"/>')
        for x, y in pts:
            out.append(f'<circle cx="{lx(x):.1f}" cy="{ly(y):.1f}" r="3" fill="{c}"/>')
        out.append(f'<text x="{L + 8}" y="{50 + 14 * i}" font-size="11" fill="{c}">{name}: slope {k:.2f}</text>')
    out.append("</g>")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--criterion", default="target/criterion")
    ap.add_argument("--out", default="docs/performance/cost.svg")
    ap.add_argument("--type", default="f64")
    a = ap.parse_args()
    by_l, by_m, rows = [], [], []
    for g in GROUPS:
        pl = [(l, median_ns(a.criterion, g, a.type, l, 64)) for l in (256, 1000, 4000)]
        # The battery regression needs L − M + 1 ≥ 8 rows: M = L only errs out.
        ms = (32, 64, 256) if g.startswith("battery") else (32, 64, 256, 4000)
        pm = [(m, median_ns(a.criterion, g, a.type, 4000, m)) for m in ms]
        pl = [(x, y) for x, y in pl if y]
        pm = [(x, y) for x, y in pm if y]
        if len(pl) < 2 or len(pm) < 2:
            sys.exit(f"error: criterion results for {g}/{a.type} missing under {a.criterion} (run the benches)")
        by_l.append((g, pl, slope(pl)))
        by_m.append((g, pm, slope(pm)))
        rows.append((g, pl, pm))
    ys = [y for _, p, _ in by_l + by_m for _, y in p]
    yr = (math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys))))
    svg = ['<svg xmlns="http://www.w3.org/2000/svg" width="860" height="300" font-family="sans-serif">',
           '<rect width="100%" height="100%" fill="white"/>']
    svg += panel(0, f"time per iteration vs L (M = 64, {a.type})", "window L (samples)", by_l,
                 (math.log10(200), math.log10(5000)), yr)
    svg += panel(430, f"time per iteration vs M (L = 4000, {a.type})", "memory M (samples)", by_m,
                 (math.log10(25), math.log10(5000)), yr)
    svg.append("</svg>")
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out, "w") as f:
        f.write("\n".join(svg) + "\n")
    print(f"| algorithm ({a.type}) | L=256 | L=1000 | L=4000 | slope in L | M=32 | M=64 | M=256 | M=4000 | slope in M |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    fmt = lambda ns: f"{ns / 1e3:.1f} µs" if ns < 1e6 else f"{ns / 1e6:.2f} ms"
    for (g, pl, pm), (_, _, kl), (_, _, km) in zip(rows, by_l, by_m):
        cells = [fmt(y) for _, y in pm] + ["n/a (M > L − 7)"] * (4 - len(pm))
        print(f"| {g} | " + " | ".join(fmt(y) for _, y in pl) + f" | {kl:.2f} | "
              + " | ".join(cells) + f" | {km:.2f} |")
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
