"""Write the variant lists of the HSLM catalogue study (study.toml) from its family.

Family (an assumption of this catalogue, not a code rule):

* simply supported single-track spans L = 10, 12.5, ..., 40 m;
* mass per length m(L) = 12 t/m + 0.3 t/m per metre of span (deck, ballast and track of
  common single-track concrete decks: 15 t/m at 10 m, 24 t/m at 40 m);
* seven first frequencies per span, geometrically spaced from the lower to the upper limit
  of the EN 1991-2 Fig. 6.10 band (vsi_numba.en1991.frequency_band), labelled "f1 band
  0/6" .. "f1 band 6/6"; the bending stiffness follows from f1 = (pi / (2 L^2)) sqrt(EI/m):
  EI = m (2 f1 L^2 / pi)^2.

Run it to regenerate the [[study.vary_together]] table printed on stdout.
"""

import numpy as np

from vsi_numba.en1991 import frequency_band

SPANS = np.arange(10.0, 40.0 + 1e-9, 2.5)
LEVELS = 7


def family():
    rows = []
    for level in range(LEVELS):
        for L in SPANS:
            lo, hi = frequency_band(L)
            f1 = lo * (hi / lo) ** (level / (LEVELS - 1))
            m = 12000.0 + 300.0 * L
            ei = m * (2.0 * f1 * L**2 / np.pi) ** 2
            rows.append((f"f1 band {level}/{LEVELS - 1}", L, float(ei), m))
    return rows


if __name__ == "__main__":
    rows = family()
    print("[[study.vary_together]]")
    print("label = [" + ", ".join(f'"{r[0]}"' for r in rows) + "]")
    print('"bridge.spans" = [' + ", ".join(f"[{r[1]:g}]" for r in rows) + "]")
    print('"bridge.EI" = [' + ", ".join(f"{r[2]:.6e}" for r in rows) + "]")
    print('"bridge.mass_per_length" = [' + ", ".join(f"{r[3]:g}" for r in rows) + "]")
