#!/usr/bin/env python3
"""Markdown tables for docs/experiments/sequential-ert.md from the sweeps'
results.csv files (medians over the successful repetitions).

    python3 scripts/sequential_ert_tables.py [RESULTS_DIR]   # default: results
"""
import csv
import statistics
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(sys.argv[1] if len(sys.argv) > 1 else "results")


def rows(name, need=()):
    """Successful runs; `need`: parameters the current config sets (rows of
    an older version of the config, without them, are left out)."""
    path = ROOT / name / "results.csv"
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f)
                if r["status"] == "ok" and all(r.get(k, "") != "" for k in need)]


def med(rs, col):
    v = [float(r[col]) for r in rs if r.get(col, "") != ""]
    return statistics.median(v) if v else float("nan")


def group(rs, keys):
    g = defaultdict(list)
    for r in rs:
        g[tuple(r.get(k, "") for k in keys)].append(r)
    return g


def view(scene):
    return "A" if "view-a" in scene else "B"


def binlabel(k):
    lo, hi = (int(x) for x in k.split(".", 1)[1].split("-"))
    return str(lo) if lo == hi else f"{lo}..{hi}"


def table(header, body):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(out)


def mode_name(r):
    if float(r["ert"]) >= 1.0:
        m = "ERT off"
    elif r["ert_structure"] == "pyramid":
        m = "pyramid (per pixel)" if r["ert_table"] == "300" else f"pyramid ({r['ert_table']}-table blocks)"
    else:
        m = f"flat {r['ert_span']} (D={r['ert_table']})"
    extra = []
    if r.get("no_partial_composition") == "true":
        extra.append("no partial comp.")
    if r.get("cell_order") == "stored":
        extra.append("stored order")
    return m + (", " + ", ".join(extra) if extra else "")


def table1():
    rs = rows("table1-sequential", ["no_partial_composition"])
    if not rs:
        return
    print("## Table 1 (results/table1-sequential)\n")
    keys = ["scene", "ert", "ert_structure", "ert_span", "ert_table", "no_partial_composition", "cell_order"]
    g = group(rs, keys)
    base = {}
    for k, v in g.items():
        r = v[0]
        if float(r["ert"]) >= 1.0:
            base[(view(r["scene"]), r["no_partial_composition"], r["cell_order"])] = (
                med(v, "time_scan_s"), min(float(x["time_scan_s"]) for x in v))
    body = []
    for k, v in g.items():
        r = v[0]
        vw = view(r["scene"])
        tsc = med(v, "time_scan_s")
        tmin = min(float(x["time_scan_s"]) for x in v)
        b, bmin = base.get((vw, r["no_partial_composition"], r["cell_order"]), (None, None))
        proj = med(v, "cells_projected")
        sk = med(v, "cells_skipped_ert")
        orc = med(v, "oracle_cells_skippable")
        ov = (med(v, "ert_update_s") + med(v, "ert_tests_s")) / tsc
        on = float(r["ert"]) < 1.0
        body.append([
            vw, mode_name(r), f"{len(v)}", f"{tsc:.4f}", f"{tmin:.4f}",
            f"{b / tsc:.2f}x / {bmin / tmin:.2f}x" if on and b else "-",
            f"{sk:.0f} ({100 * sk / proj:.1f} %)" if on else "-",
            f"{orc:.0f} ({100 * orc / proj:.1f} %)" if on else "-",
            f"{100 * sk / orc:.1f} %" if on and orc == orc else "-",
            f"{1000 * med(v, 'ert_update_s'):.2f} / {1000 * med(v, 'ert_tests_s'):.2f}" if on else "-",
            f"{100 * ov:.1f} %" if on else "-",
        ])
    body.sort(key=lambda x: x[0])
    print(table(["view", "mode", "runs", "Tsc median [s]", "Tsc min [s]", "speed-up vs ERT off (same order and partial comp.), medians / minima",
                 "cells skipped (of projected)", "oracle skippable", "skipped / oracle",
                 "T_update / tests [ms]", "(T_update + tests) / Tsc"], body))
    print()


def fig11():
    rs = rows("fig11-table-size")
    if not rs:
        return
    print("## Fig. 11 (results/fig11-table-size)\n")
    for vw in ["B", "A"]:
        sub = [r for r in rs if view(r["scene"]) == vw]
        g = group(sub, ["ert_table", "ert", "ert_structure", "ert_span", "ert_update", "no_partial_composition"])
        ds = sorted({int(r["ert_table"]) for r in sub})
        modes = []
        for k in g:
            if float(k[1]) < 1.0 and k[1:] not in modes:
                modes.append(k[1:])
        print(f"### View {vw}: cells skipped | Tsc / Tsc(ERT off, same D) | T_update [ms]\n")
        body = []
        for d in ds:
            off = med(g[(str(d), "1") + ("flat", "single", "100", "false")], "time_scan_s")
            row = [str(d), f"{off:.3f}"]
            for m in modes:
                v = g[(str(d),) + m]
                row.append(f"{med(v, 'cells_skipped_ert'):.0f} \\| {med(v, 'time_scan_s') / off:.2f} \\| {1000 * med(v, 'ert_update_s'):.1f}")
            body.append(row)
        names = []
        for m in modes:
            _, st, sp, c, npc = m
            names.append(f"{st} {sp} C={c}" + (" no PC" if npc == "true" else ""))
        print(table(["D", "Tsc off [s]"] + names, body))
        print()
        # Best D per mode by cells skipped.
        for m, n in zip(modes, names):
            best = max(ds, key=lambda d: med(g[(str(d),) + m], "cells_skipped_ert"))
            bt = min(ds, key=lambda d: med(g[(str(d),) + m], "time_scan_s") / med(g[(str(d), "1", "flat", "single", "100", "false")], "time_scan_s"))
            print(f"- {n}: most cells skipped at D = {best}; lowest Tsc/Tsc(off) at D = {bt}")
        print()
    # Cell sizes (deterministic: take the ERT-off rows at D = 20).
    print("### Fig. 11(3): projected cell sizes (bounding box of pixel centres)\n")
    for vw in ["B", "A"]:
        r = next(r for r in rs if view(r["scene"]) == vw and float(r["ert"]) >= 1.0)
        tot = sum(int(r[k] or 0) for k in r if k.startswith("cell_extent_hist."))
        print(f"View {vw} ({r['width']}x{r['height']}): {tot} cells; larger side p50 = {r['cell_extent_p50']}, "
              f"p90 = {r['cell_extent_p90']}, p99 = {r['cell_extent_p99']} px; pixels in the box mean = "
              f"{float(r['cell_pixels_mean']):.1f}, p50 = {r['cell_pixels_p50']}, p90 = {r['cell_pixels_p90']}\n")
        for h in ["cell_extent_hist", "cell_pixels_hist"]:
            ks = sorted(k for k in r if k.startswith(h + ".") and r[k] not in ("", "0"))
            print(table(["bin (" + ("larger side, px" if "extent" in h else "pixels in box") + ")"] + [binlabel(k) for k in ks],
                        [["cells"] + [r[k] for k in ks], ["share"] + [f"{100 * int(r[k]) / tot:.1f} %" for k in ks]]))
            print()


def fig12():
    rs = rows("fig12-update-frequency")
    # The per-pixel pyramid is ert_table = 300 (older runs used 20-table blocks).
    rs = [r for r in rs if r["ert_structure"] == "flat" or r["ert_table"] == "300"]
    if not rs:
        return
    print("## Fig. 12 (results/fig12-update-frequency): cells skipped | Tsc [s] | T_update [s]\n")
    keys = ["ert_structure", "cell_order", "no_partial_composition"]
    g = group(rs, keys + ["ert_update"])
    cs = sorted({int(r["ert_update"]) for r in rs})
    series = sorted({k[:3] for k in g})
    body = []
    for c in cs:
        row = [str(c)]
        for s in series:
            v = g.get(s + (str(c),), [])
            row.append(f"{med(v, 'cells_skipped_ert'):.0f} \\| {med(v, 'time_scan_s'):.3f} \\| {med(v, 'ert_update_s'):.3f}" if v else "-")
        body.append(row)
    names = [f"{s[0]}, {s[1]}" + (", no PC" if s[2] == "true" else ", PC") for s in series]
    print(table(["C"] + names, body))
    print()
    for s, n in zip(series, names):
        best = max(cs, key=lambda c: med(g[s + (str(c),)], "cells_skipped_ert"))
        bt = min(cs, key=lambda c: med(g[s + (str(c),)], "time_scan_s"))
        print(f"- {n}: most cells skipped at C = {best}; lowest Tsc at C = {bt}")
    print()


table1()
fig11()
fig12()
