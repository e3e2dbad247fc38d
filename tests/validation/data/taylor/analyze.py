#!/usr/bin/env python3
"""Extract Taylor-bar length and foot radius from NairnMPM archives.
usage: analyze.py <run_dir> <name> <cell_size_mm> <axi|3d>
Needs ExtractMPM (NairnMPM/tools) on $EXTRACTMPM or the default path below."""
import glob, json, os, re, subprocess, sys
import numpy as np

EX = os.environ.get("EXTRACTMPM", "/work/nairn/NairnMPM/tools/ExtractMPM")

def read_archive(path, threed):
    out = path + ".tmp"
    q = ["-q", "dispx", "-q", "dispy"] + (["-q", "dispz"] if threed else []) + ["-q", "hist1"]
    subprocess.run([EX] + (["-3"] if threed else []) + ["-h"] + q + ["-o", out, path],
                   check=True, stdout=subprocess.DEVNULL)
    t = None
    with open(out + ".txt") as f:
        for line in f:
            if line.startswith("Time"):
                t = float(line.split()[1])
            if line.startswith("EndHeader"):
                break
        a = np.loadtxt(f)
    os.remove(out + ".txt")
    return t, a

def measure(run_dir, name, h, kind):
    threed = kind == "3d"
    files = glob.glob(os.path.join(run_dir, f"{name}_out", f"{name}.[0-9]*"))
    files.sort(key=lambda p: int(p.rsplit(".", 1)[1]))
    lp = h / 4.0                      # undeformed particle half-width (2 particles per cell per direction)
    hist = []
    for p in files:
        t, a = read_archive(p, threed)
        if threed:
            x, y, z, dx, dy, dz, alpha = a.T
            r, ax = np.hypot(x, y), z
            r0, ax0 = np.hypot(x - dx, y - dy), z - dz
        else:
            x, y, dx, dy, alpha = a.T
            r, ax = x, y
            r0, ax0 = x - dx, y - dy
        bottom = ax0 < ax0.min() + 1e-6 * h + 1e-9      # particles of the initial bottom layer
        bottom = np.abs(ax0 - ax0.min()) < 0.25 * lp
        top = np.abs(ax0 - ax0.max()) < 0.25 * lp
        hist.append(dict(
            t_us=round(t * 1000.0, 4),
            L_centres=float(ax.max()),
            L_centres_plus_half=float(ax.max() + lp),
            L_top_layer_mean=float(ax[top].mean() + lp),
            R_foot_centres=float(r[bottom].max()),
            R_foot_centres_plus_half=float(r[bottom].max() + lp),
            R_max_all_centres=float(r.max()),
            z_of_R_max_all=float(ax[np.argmax(r)]),
            min_axial=float(ax.min()),
            alpha_max=float(alpha.max()),
            n=int(len(r)),
            R0_centres_max=float(r0.max()),
        ))
    return hist

if __name__ == "__main__":
    run_dir, name, h, kind = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
    print(json.dumps(measure(run_dir, name, h, kind), indent=1))
