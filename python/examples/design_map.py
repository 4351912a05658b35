"""A design map: how much the ball damper reduces the vibration, over frequency ratio × gap,
and the gap that is best over the whole band of ratios.

    python python/examples/design_map.py [--out DIR] [--quick]

Needs matplotlib; writes DIR/design_map.png and DIR/design_map.csv (the same CSV as
``vibrobar map``). With xarray installed, the map is also shown as a Dataset.
"""

import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import vibrobar


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="output directory")
    ap.add_argument("--quick", action="store_true", help="a coarse grid of 0.3 s runs (smoke test)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    if a.quick:
        sc = vibrobar.Scenario.paper(duration_s=0.3)
        ratios = np.linspace(0.96, 1.04, 5)
        gaps_m = np.array([0.05, 0.1, 0.3, 1.0]) * 1e-3
    else:
        sc = vibrobar.Scenario.paper()
        ratios = np.linspace(0.94, 1.06, 25)
        gaps_m = np.geomspace(0.02e-3, 2e-3, 15)
    m = vibrobar.map(sc, ratios, gaps_m, progress=True)

    # The grid as a 2-d array: rows gaps, columns ratios.
    red = np.full((len(gaps_m), len(ratios)), np.nan)
    gi = np.searchsorted(np.sort(gaps_m * 1e3), m["gap_mm"])
    ri = np.searchsorted(np.sort(ratios), m["ratio"])
    red[gi, ri] = m["reduction_pct"]

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    pc = ax.pcolormesh(np.sort(ratios), np.sort(gaps_m) * 1e3, red, shading="nearest", cmap="viridis")
    fig.colorbar(pc, ax=ax, label="RMS reduction (%)")
    ax.set_yscale("log")
    ax.set_xlabel("frequency ratio Ω/ω₁")
    ax.set_ylabel("gap (mm)")
    band = np.nanmean(red, axis=1)
    best = int(np.nanargmax(band))
    ax.axhline(np.sort(gaps_m)[best] * 1e3, color="w", ls="--", lw=1)
    ax.set_title(f"Design map: best gap over the band {np.sort(gaps_m)[best] * 1e3:.3g} mm")
    fig.tight_layout()
    png = os.path.join(a.out, "design_map.png")
    fig.savefig(png, dpi=120)
    with open(os.path.join(a.out, "design_map.csv"), "w") as f:
        f.write(m.to_csv())
    try:
        print(m.to_xarray())
    except ImportError:
        pass
    print(f"wrote {png}; best gap over the band {np.sort(gaps_m)[best] * 1e3:.3g} mm "
          f"(mean reduction {band[best]:.1f} %)")


if __name__ == "__main__":
    main()
