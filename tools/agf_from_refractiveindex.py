#!/usr/bin/env python3
"""Writes lensdata/data/vendor_glass.agf from the refractiveindex.info database.

The database (https://github.com/polyanskiy/refractiveindex.info-database, public domain,
CC0 1.0) keeps every glass of the HOYA (2017-04-01), NIKON (2017-11) and SUMITA (2017-02-02)
Zemax catalogs as a YAML file under database/data/specs/<vendor>/optical/: the vendor's
dispersion fit ("formula 3": n^2 = C1 + sum C_i lambda^e_i, lambda in um), its validity range,
the extinction coefficient k tabulated against wavelength, nd, Vd, the glass code and status,
thermal data. This tool turns them back into AGF, one veil-catalog block per vendor:

  formula 3 with exponents        AGF formula
  2, -2, -4, -6, -8               1 Schott
  2, -2 ... -12                   10 Extended 1
  2, 4, -2 ... -8 (and 6)         12 Extended 2
  2, 4, -2 ... -12                13 Extended 3

(the same polynomial, its terms in the AGF formula's order); k becomes internal transmittance
rows for 10 mm of glass, tau = exp(-4 pi k d / lambda); the thermal dispersion ("formula A":
D0 D1 D2 E0 E1 lambda_tk) a TD row at the stated temperature. A glass whose fit fits none of
the formulas above stops the tool with its file named.

usage: tools/agf_from_refractiveindex.py DATABASE_CHECKOUT > lensdata/data/vendor_glass.agf
Needs python3-yaml. Not part of the build: the AGF it writes is committed.
"""

import glob
import math
import os
import sys

import yaml

VENDORS = [
    # (catalog name, folder under database/data/specs, source named in the file)
    ("HOYA", "hoya", "HOYA Zemax catalog 2017-04-01"),
    ("NIKON", "hikari", "NIKON Zemax catalog 2017-11 (Hikari glasses)"),
    ("SUMITA", "sumita", "SUMITA Zemax catalog 2017-02-02"),
]

# AGF formula number -> the exponent of lambda each coefficient after the constant multiplies.
FORMULAS = [
    (1, [2, -2, -4, -6, -8]),
    (10, [2, -2, -4, -6, -8, -10, -12]),
    (12, [2, -2, -4, -6, -8, 4, 6]),
    (13, [2, 4, -2, -4, -6, -8, -10, -12]),
]

STATUS = {None: 0, "standard": 0, "preferred": 1, "obsolete": 2, "special": 3, "melt": 4}

IT_THICKNESS_MM = 10.0


def number(x):
    """Shortest text that reads back to the same double."""
    r = repr(float(x))
    return r[:-2] if r.endswith(".0") else r


def agf_formula(path, coefficients):
    c = [float(v) for v in str(coefficients).split()]
    constant, terms = c[0], {}
    for value, exponent in zip(c[1::2], c[2::2]):
        if exponent == 0:
            constant += value
        else:
            terms[int(exponent)] = terms.get(int(exponent), 0.0) + value
    for agf, exponents in FORMULAS:
        if set(terms) <= set(exponents):
            return agf, [constant] + [terms.get(e, 0.0) for e in exponents]
    sys.exit(f"{path}: no AGF formula has the exponents {sorted(terms)}")


def index(agf, cd, lam):
    exponents = dict(FORMULAS)[agf]
    n2 = cd[0] + sum(v * lam**e for v, e in zip(cd[1:], exponents))
    return math.sqrt(n2)


def glass_lines(path, name):
    d = yaml.safe_load(open(path, encoding="utf-8"))
    formula = [e for e in d["DATA"] if e["type"] == "formula 3"]
    if len(formula) != 1:
        sys.exit(f"{path}: expected one 'formula 3' entry")
    agf, cd = agf_formula(path, formula[0]["coefficients"])
    lo, hi = (float(v) for v in str(formula[0]["wavelength_range"]).split())
    p = d.get("PROPERTIES") or {}
    nd = p.get("nd")
    vd = p.get("Vd")
    if nd is None or vd is None:
        # d, F and C lines (um): the values the vendor's fit gives.
        n_d, n_f, n_c = (index(agf, cd, l) for l in (0.5875618, 0.4861327, 0.6562725))
        nd, vd = n_d, (n_d - 1.0) / (n_f - n_c)
    code = p.get("glass_code")
    mil = f"{code:06d}" if isinstance(code, int) else (
        f"{round((float(nd) - 1.0) * 1000):03d}{round(float(vd) * 10):03d}")
    status = STATUS.get(p.get("glass_status"))
    if status is None:
        sys.exit(f"{path}: unknown glass_status {p.get('glass_status')!r}")
    lines = [f"NM {name} {agf} {mil} {number(nd)} {number(vd)} 0 {status}"]
    comment = " ".join(str(d.get("COMMENTS") or "").split())
    if comment:
        lines.append(f"GC {comment}")

    def first(key, pick):
        v = p.get(key)
        try:
            return number(pick(v)) if v is not None else "-"
        except (KeyError, IndexError, TypeError, ValueError):
            return "-"

    def expansion(rng):
        for e in p.get("thermal_expansion") or []:
            if [float(x) for x in str(e.get("temperature_range", "")).split()] == rng:
                return number(float(e["value"]) * 1e6)
        return "-"

    density = first("density", lambda v: float(v[0]["value"]) / 1000.0)
    lines.append(f"ED {expansion([243.0, 343.0])} {expansion([373.0, 573.0])} {density} "
                 f"{first('dPgF', float)} 0")
    lines.append("CD " + " ".join(number(v) for v in cd))
    td = p.get("thermal_dispersion") or []
    td = [t for t in td if t.get("type") == "formula A"]
    if td:
        t = [float(v) for v in str(td[0]["coefficients"]).split()]
        temperature = float((d.get("CONDITIONS") or {}).get("temperature", 293.15)) - 273.15
        lines.append("TD " + " ".join(number(v) for v in t[:6]) + f" {round(temperature):d}")
    lines.append(f"LD {number(lo)} {number(hi)}")
    for e in d["DATA"]:
        if e["type"] != "tabulated k":
            continue
        for row in str(e["data"]).strip().splitlines():
            lam, k = (float(v) for v in row.split())
            if k < 0.0:
                # A transmittance above 1 in the vendor's table (a typo there): left out.
                lines.append(f"! {name}: the transmittance row at {number(lam)} um is left out "
                             f"(k = {number(k)} < 0 in the source)")
                print(f"{path}: row at {lam} um left out (k < 0)", file=sys.stderr)
                continue
            tau = math.exp(-4.0 * math.pi * k * IT_THICKNESS_MM / (lam * 1e-3))
            lines.append(f"IT {number(lam)} {round(tau, 4):g} {number(IT_THICKNESS_MM)}")
    return lines


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    root = os.path.join(sys.argv[1], "database", "data", "specs")
    out = [
        "! veil built-in vendor catalogs: HOYA, NIKON (Hikari glasses) and SUMITA. Generated by",
        "! tools/agf_from_refractiveindex.py from the refractiveindex.info database",
        "! (github.com/polyanskiy/refractiveindex.info-database, public domain, CC0 1.0), which",
        "! keeps the vendors' Zemax catalogs glass by glass. Internal transmittance rows are for",
        f"! {IT_THICKNESS_MM:g} mm of glass, from the tabulated extinction coefficient k. Do not edit:",
        "! run the tool again.",
    ]
    for catalog, folder, source in VENDORS:
        files = sorted(glob.glob(os.path.join(root, folder, "optical", "*.yml")))
        if not files:
            sys.exit(f"{root}/{folder}/optical: no glasses")
        out.append(f"CC veil-catalog {catalog}")
        out.append(f"CC {source}, via the refractiveindex.info database (CC0 1.0)")
        for f in files:
            out.extend(glass_lines(f, os.path.splitext(os.path.basename(f))[0]))
    sys.stdout.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
