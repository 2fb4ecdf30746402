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

(the same polynomial, its terms in the AGF formula's order). It also keeps materials outside
those catalogs as the makers' data sheets give them: Schott's glasses that left the optical
catalog or were never in it (ZERODUR, BOROFLOAT 33, LF7; LITHOSIL-Q, LITHOTEC-CAF2, D 263 T
eco and AF 32 eco are in builtin_glass.agf already) and its IRG infrared chalcogenides, added
to SCHOTT, and the infrared glasses
of Amorphous Materials (AMTIR-2, AMTIR-3) and Vitron (IG2 to IG6), added to the INFRARED
catalog that lensdata/data/crystals.agf starts.
Their fits are Sellmeier sums ("formula 1": n^2 - 1 = C0 + sum B_i lambda^2 / (lambda^2 - C_i^2);
"formula 2": the same with C_i for C_i^2):

  C0 = 0, up to 3 / 4 / 5 terms   AGF 2 Sellmeier 1 / 6 Sellmeier 3 / 11 Sellmeier 5
  C0 != 0, up to 2 terms          AGF 9 Sellmeier 4 (A = 1 + C0)

and each such glass carries its source (the database's references) in a GC line. Where the
source gives no nd and Vd they are the fit's at d, F and C, extrapolated for an infrared glass
(labels, as in the makers' Zemax catalogs). k becomes internal transmittance
rows for 10 mm of glass, tau = exp(-4 pi k d / lambda); the thermal dispersion ("formula A":
D0 D1 D2 E0 E1 lambda_tk) a TD row at the stated temperature. A glass whose fit fits none of
the formulas above stops the tool with its file named.

usage: tools/agf_from_refractiveindex.py DATABASE_CHECKOUT > lensdata/data/vendor_glass.agf
Needs python3-yaml. Not part of the build: the AGF it writes is committed.
"""

import glob
import math
import re
import os
import sys

import yaml

# In lensdata/data/builtin_glass.agf already (Schott's own catalog): not written again.
BUILT_IN = {"AF32ECO", "D263TECO", "LITHOSIL-Q", "LITHOTEC-CAF2"}

VENDORS = [
    # (catalog name, folders under database/data/specs, source named in the file, whether
    # each glass names its own source)
    ("HOYA", ["hoya/optical"], "HOYA Zemax catalog 2017-04-01", False),
    ("NIKON", ["hikari/optical"], "NIKON Zemax catalog 2017-11 (Hikari glasses)", False),
    ("SUMITA", ["sumita/optical"], "SUMITA Zemax catalog 2017-02-02", False),
    ("SCHOTT", ["schott/misc", "schott/obsolete", "schott/infrared"],
     "SCHOTT materials outside its optical glass catalog: data sheets and the 2017-01-20b "
     "Zemax catalog, each glass's source in its GC line", True),
    ("INFRARED", ["ami/infrared", "vitron/infrared"],
     "infrared glasses of Amorphous Materials and Vitron: data sheets, each glass's source in "
     "its GC line", True),
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


SELLMEIER_TERMS = {2: 3, 6: 4, 11: 5}  # AGF formula -> its terms (no constant)


def sellmeier_formula(path, kind, coefficients):
    """AGF formula and coefficients of a database Sellmeier fit ("formula 1" or "formula 2")."""
    c = [float(v) for v in str(coefficients).split()]
    if len(c) % 2 != 1:
        sys.exit(f"{path}: a Sellmeier fit needs C0 and pairs of coefficients")
    constant = c[0]
    terms = [(b, p * p if kind == "formula 1" else p) for b, p in zip(c[1::2], c[2::2])]
    if constant == 0.0:
        for agf, count in sorted(SELLMEIER_TERMS.items(), key=lambda x: x[1]):
            if len(terms) <= count:
                terms += [(0.0, 0.0)] * (count - len(terms))
                return agf, [v for t in terms for v in t]
    elif len(terms) <= 2:
        terms += [(0.0, 0.0)] * (2 - len(terms))
        return 9, [1.0 + constant] + [v for t in terms for v in t]
    sys.exit(f"{path}: no AGF formula holds this Sellmeier fit ({len(terms)} terms, "
             f"C0 = {constant})")


def index(agf, cd, lam):
    l2 = lam * lam
    if agf in SELLMEIER_TERMS:
        n2 = 1.0 + sum(k * l2 / (l2 - l) for k, l in zip(cd[0::2], cd[1::2]))
    elif agf == 9:
        n2 = cd[0] + cd[1] * l2 / (l2 - cd[2]) + cd[3] * l2 / (l2 - cd[4])
    else:
        exponents = dict(FORMULAS)[agf]
        n2 = cd[0] + sum(v * lam**e for v, e in zip(cd[1:], exponents))
    if not n2 > 0.0:
        sys.exit(f"formula {agf} gives n^2 = {n2} at {lam} um")
    return math.sqrt(n2)


def ascii_text(text):
    """AGF comments in ASCII: the few non-ASCII signs of the sources spelled out."""
    for sign, word in (("\u00b0", "deg "), ("\u2013", "-"), ("\u2014", "-"), ("\u00ae", ""),
                       ("\u00b5", "u")):
        text = text.replace(sign, word)
    return text.encode("ascii", "replace").decode("ascii")


def plain(html):
    """The database's references as one line of text: tags dropped, links kept."""
    text = re.sub(r'<a href="([^"]*)">(.*?)</a>', r"\2 (\1)", str(html or ""))
    text = re.sub(r"<[^>]+>", " ", text).replace("&amp;", "&")
    return " ".join(text.split())


def glass_lines(path, name, cite):
    d = yaml.safe_load(open(path, encoding="utf-8"))
    formula = [e for e in d["DATA"] if e["type"] in ("formula 1", "formula 2", "formula 3")]
    if cite and not formula:
        # A data sheet's table of n alone: no fit to carry over.
        print(f"{path}: tabulated n only, left out", file=sys.stderr)
        return [f"! {name}: the source tabulates n without a dispersion fit; not included"]
    if len(formula) != 1:
        sys.exit(f"{path}: expected one 'formula 1', '2' or '3' entry")
    if formula[0]["type"] == "formula 3":
        agf, cd = agf_formula(path, formula[0]["coefficients"])
    else:
        agf, cd = sellmeier_formula(path, formula[0]["type"], formula[0]["coefficients"])
    lo, hi = (float(v) for v in str(formula[0]["wavelength_range"]).split())
    p = d.get("PROPERTIES") or {}
    nd = p.get("nd")
    vd = p.get("Vd")
    visible = lo <= 0.4861327 and 0.6562725 <= hi
    if (nd is None or vd is None) and not visible:
        # An infrared glass opaque at d: as GERMANIUM in crystals.agf, the NM line's nd and Vd
        # label the entry with the index at 10.6 um and the 8-12 um Abbe number.
        if not (lo <= 8.0 and 12.0 <= hi):
            sys.exit(f"{path}: no nd and Vd given, and the fit covers neither F and C nor 8-12 um")
        n8, n10, n106, n12 = (index(agf, cd, l) for l in (8.0, 10.0, 10.6, 12.0))
        nd, vd = n106, (n10 - 1.0) / (n8 - n12)
    elif nd is None or vd is None:
        # d, F and C lines (um): the values the vendor's fit gives.
        n_d, n_f, n_c = (index(agf, cd, l) for l in (0.5875618, 0.4861327, 0.6562725))
        nd, vd = n_d, (n_d - 1.0) / (n_f - n_c)
    code = p.get("glass_code")
    if isinstance(code, int):
        mil = f"{code:06d}"
    elif visible or p.get("nd") is not None:
        mil = f"{round((float(nd) - 1.0) * 1000):03d}{round(float(vd) * 10):03d}"
    else:
        mil = "0"  # no glass code for an infrared label
    status = STATUS.get(p.get("glass_status"))
    if status is None:
        sys.exit(f"{path}: unknown glass_status {p.get('glass_status')!r}")
    lines = [f"NM {name} {agf} {mil} {number(nd)} {number(vd)} 0 {status}"]
    comment = " ".join(str(d.get("COMMENTS") or "").split())
    # One GC line per glass: the file's comment, and for a cited glass its source and what
    # its nd and Vd are.
    gc = [ascii_text(comment) if cite else comment] if comment else []
    if cite:
        gc.append(f"source: {ascii_text(plain(d.get('REFERENCES')))}")
        if p.get("nd") is None and not visible:
            gc.append("opaque at d: nd and Vd label the entry, n at 10.6 um and the 8-12 um "
                      "Abbe number (n10 - 1) / (n8 - n12)")
    if gc:
        lines.append("GC " + "; ".join(gc))

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
        "! veil built-in vendor catalogs: HOYA, NIKON (Hikari glasses), SUMITA, Schott materials",
        "! outside its optical glass catalog (added to SCHOTT) and INFRARED. Generated by",
        "! tools/agf_from_refractiveindex.py from the refractiveindex.info database",
        "! (github.com/polyanskiy/refractiveindex.info-database, public domain, CC0 1.0), which",
        "! keeps the vendors' Zemax catalogs glass by glass. Internal transmittance rows are for",
        f"! {IT_THICKNESS_MM:g} mm of glass, from the tabulated extinction coefficient k. Do not edit:",
        "! run the tool again.",
    ]
    for catalog, folders, source, cite in VENDORS:
        out.append(f"CC veil-catalog {catalog}")
        out.append(f"CC {source}, via the refractiveindex.info database (CC0 1.0)")
        for folder in folders:
            files = sorted(glob.glob(os.path.join(root, folder, "*.yml")))
            if not files:
                sys.exit(f"{root}/{folder}: no glasses")
            for f in files:
                name = os.path.splitext(os.path.basename(f))[0]
                if name not in BUILT_IN:
                    out.extend(glass_lines(f, name, cite))
    sys.stdout.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
