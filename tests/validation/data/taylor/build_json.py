#!/usr/bin/env python3
"""Collect the NairnMPM Taylor-bar runs into taylor_reference.json.
usage: build_json.py <run_dir>   (expects <name>.hist.json from analyze.py and <name>.mpm)"""
import json, os, re, sys
run_dir = sys.argv[1]
here = os.path.dirname(os.path.abspath(__file__))
RUNS = [  # name, model, cell size, note
    ("taylor_axi_h0.4", "axisymmetric", 0.4, "reference setting (default hypoelastic/Jaumann path)"),
    ("taylor_axi_h0.2", "axisymmetric", 0.2, "reference setting"),
    ("taylor_axi_h0.1", "axisymmetric", 0.1, "reference setting"),
    ("taylor_3dq_h0.8", "3D quarter", 0.8, "reference setting"),
    ("taylor_3dq_h0.4", "3D quarter", 0.4, "reference setting"),
    ("taylor_axi_h0.4_fix", "axisymmetric", 0.4, "SENSITIVITY ONLY: NairnMPM patched (IsoPlasticity.cpp line 252: 2D Jaumann s_xy term uses (s_xx-s_yy) instead of the plastic strain (ep_xx-ep_yy)); not the reference"),
    ("taylor_axi_h0.4_lr", "axisymmetric", 0.4, "SENSITIVITY ONLY: <largeRotation>1 (polar-decomposition, Biot-stretch increments); gives a much smaller foot, see 'largeRotation_warning'; not the reference"),
    ("taylor_3dq_h0.8_lr", "3D quarter", 0.8, "SENSITIVITY ONLY: <largeRotation>1; see 'largeRotation_warning'; not the reference"),
]

def mpm_info(path):
    s = open(path).read()
    g = lambda pat: (re.search(pat, s).group(1) if re.search(pat, s) else None)
    return dict(particles=int(g(r"Number of Material Points: (\d+)")),
                steps=int(g(r"Calculation Steps: (\d+)")),
                elapsed_s=float(g(r"Elapsed Time: ([0-9.]+) secs")),
                cpu_s=float(g(r"CPU Time: ([0-9.]+) secs")),
                dt_ms=float(g(r"Adjusted time step \(ms\): ([0-9.eE+-]+)")))

runs = {}
for name, model, h, note in RUNS:
    hj = os.path.join(run_dir, name + ".hist.json")
    mp = os.path.join(run_dir, name + ".mpm")
    if not (os.path.exists(hj) and os.path.exists(mp)) or "RUN COMPLETED" not in open(mp).read():
        continue
    hist = json.load(open(hj))
    info = mpm_info(mp)
    last = hist[-1]
    runs[name] = dict(
        model=model, cell_mm=h, particles_per_cell=(4 if model == "axisymmetric" else 8),
        particle_half_width_mm=h / 4, note=note,
        input=("nairnmpm/" + name + ".xml") if not name.endswith("_fix") else ("nairnmpm/" + name + ".xml (run with the patched binary)"),
        **info,
        t_final_us=last["t_us"],
        L_f_mm=round(last["L_centres_plus_half"], 4),
        R_f_mm=round(last["R_foot_centres_plus_half"], 4),
        L_f_centres_mm=round(last["L_centres"], 4),
        R_f_centres_mm=round(last["R_foot_centres"], 4),
        R_max_any_particle_centre_mm=round(last["R_max_all_centres"], 4),
        alpha_max=round(last["alpha_max"], 4),
        initial_max_particle_centre_radius_mm=round(hist[0]["R0_centres_max"], 4),
        history=[dict(t_us=e["t_us"], L_mm=round(e["L_centres_plus_half"], 4),
                      R_foot_mm=round(e["R_foot_centres_plus_half"], 4),
                      L_centres_mm=round(e["L_centres"], 4), R_foot_centres_mm=round(e["R_foot_centres"], 4),
                      alpha_max=round(e["alpha_max"], 4)) for e in hist],
    )

doc = json.load(open(os.path.join(here, "taylor_reference_header.json")))
doc["runs"] = runs
def pct(a, b):
    return round(100.0 * (a - b) / b, 3)
cmp = {}
pairs = [("taylor_axi_h0.4", "taylor_axi_h0.2"), ("taylor_axi_h0.2", "taylor_axi_h0.1"),
         ("taylor_3dq_h0.8", "taylor_3dq_h0.4"), ("taylor_3dq_h0.4", "taylor_axi_h0.4"),
         ("taylor_3dq_h0.4", "taylor_axi_h0.2"), ("taylor_3dq_h0.8", "taylor_axi_h0.4"),
         ("taylor_axi_h0.4_fix", "taylor_axi_h0.4"), ("taylor_axi_h0.4_lr", "taylor_axi_h0.4"),
         ("taylor_3dq_h0.8_lr", "taylor_3dq_h0.8")]
for a, b in pairs:
    if a in runs and b in runs:
        cmp[a + " vs " + b] = dict(
            L_f_pct=pct(runs[a]["L_f_mm"], runs[b]["L_f_mm"]), R_f_pct=pct(runs[a]["R_f_mm"], runs[b]["R_f_mm"]),
            L_f_centres_pct=pct(runs[a]["L_f_centres_mm"], runs[b]["L_f_centres_mm"]),
            R_f_centres_pct=pct(runs[a]["R_f_centres_mm"], runs[b]["R_f_centres_mm"]))
doc["comparison"] = cmp
json.dump(doc, open(os.path.join(here, "taylor_reference.json"), "w"), indent=1)
print("wrote", len(runs), "runs")
