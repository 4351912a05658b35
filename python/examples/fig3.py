"""Redraw Fig. 3 of the paper: RMS of the bar displacement against the forcing frequency ratio,
solid bar and impact-damped bar (gaps 0.1 mm and 1 mm), without friction.

    python python/examples/fig3.py [--out DIR] [--quick]

Needs matplotlib (``pip install matplotlib``); writes DIR/fig3.png and DIR/fig3.csv (the same CSV
as ``vibrobar sweep``).
"""

import argparse
import os

import matplotlib

matplotlib.use("Agg")  # files only; no display needed
import matplotlib.pyplot as plt
import numpy as np

import vibrobar


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="output directory")
    ap.add_argument("--quick", action="store_true", help="0.3 s runs instead of the paper's 2 s (smoke test)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    sc = vibrobar.Scenario.paper(friction="none", **({"duration_s": 0.3} if a.quick else {}))
    ratios = np.round(np.arange(0.95, 1.05 + 1e-9, 0.0025), 6)
    s = vibrobar.sweep(sc, ratios=ratios, gaps_m=[0.1e-3, 1.0e-3], progress=None)

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    first = s["gap_mm"] == s["gap_mm"][0]
    ax.plot(s["ratio"][first], s["rms_solid_m"][first] * 1e6, "k-", label="solid bar")
    for gap_mm, style in [(0.1, "o-"), (1.0, "s--")]:
        k = s["gap_mm"] == gap_mm
        ax.plot(s["ratio"][k], s["rms_damped_m"][k] * 1e6, style, ms=3, label=f"impact damper, gap {gap_mm:g} mm")
    ax.set_xlabel("frequency ratio Ω/ω₁")
    ax.set_ylabel("RMS of u (µm)")
    ax.set_title("Fig. 3: RMS without friction" + (" (quick)" if a.quick else ""))
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    png = os.path.join(a.out, "fig3.png")
    fig.savefig(png, dpi=120)
    with open(os.path.join(a.out, "fig3.csv"), "w") as f:
        f.write(s.to_csv())
    best = int(np.argmax(s["reduction_pct"]))
    print(
        f"wrote {png}; largest reduction {s['reduction_pct'][best]:.1f} % "
        f"at ratio {s['ratio'][best]:g}, gap {s['gap_mm'][best]:g} mm"
    )


if __name__ == "__main__":
    main()
