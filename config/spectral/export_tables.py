#!/usr/bin/env python3
"""Export the colorimetric tables used by spectex from colour-science.

Run:  /tmp/datavenv/bin/python config/spectral/export_tables.py
(venv: python3 -m venv /tmp/datavenv && /tmp/datavenv/bin/pip install colour-science==0.4.7 numpy)

Writes the CSV files next to this script (observers, illuminants D50 D55 D65 D75 A FL1-FL12 and the
CIE LED series, the Mallett 2019 basis, ColorChecker). Output is deterministic: values are
taken as shipped (no interpolation) and written with repr() of the float.
"""

import os
import warnings

warnings.filterwarnings("ignore")  # colour warns about optional SciPy/Matplotlib

import colour  # noqa: E402
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
EXPORTER = (f"exported from colour-science {colour.__version__} (BSD-3-Clause) "
            "by config/spectral/export_tables.py")
CIE_LICENCE = ("licence: CIE standard data, freely distributed by the CIE; "
               "colour-science transcription BSD-3-Clause")
CMFS_SOURCE = ("CIE S 014-1/E:2006 (ISO/CIE 11664-1) standard colorimetric observers, "
               "CIE 015:2018 tables; colour-science takes them from CVRL (cvrl.org)")
ILLUM_SOURCE = {
    "D65": "CIE standard illuminant D65, ISO/CIE 11664-2 (CIE S 014-2/E:2006), CIE 015:2018 tables",
    "A": "CIE standard illuminant A, ISO/CIE 11664-2 (CIE S 014-2/E:2006), CIE 015:2018 tables",
    "FL11": "CIE illuminant F11 (fluorescent, tri-band), CIE 015:2018 / CIE 15:2004 tables",
}
# CIE daylight illuminants and their nominal CCT (K, on the pre-1968 c2 = 1.4380e-2 m K scale).
DAYLIGHT_CCT = {"D50": 5000, "D55": 5500, "D65": 6500, "D75": 7500}
for _key in ["D50", "D55", "D75"]:
    _cct = round(DAYLIGHT_CCT[_key] * 1.4388 / 1.4380)
    ILLUM_SOURCE[_key] = f"CIE illuminant {_key} (daylight, CCT {_cct} K), CIE 015:2018 / CIE 15:2004 tables"
# CIE 015:2018 groups of the F illuminants: standard halophosphate (F1-F6), broadband (F7-F9),
# narrow tri-band (F10-F12).
for _k in range(1, 13):
    if _k != 11:  # FL11's line predates the others and stays as it was (byte-identical file)
        _kind = "standard halophosphate" if _k <= 6 else "broadband" if _k <= 9 else "tri-band"
        ILLUM_SOURCE[f"FL{_k}"] = (f"CIE illuminant F{_k} (fluorescent, {_kind}), "
                                   "CIE 015:2018 / CIE 15:2004 tables")
# CIE 015:2018 LED illuminants (typical white LEDs) by kind of source.
LED_KIND = {
    "LED-B1": "phosphor-converted blue", "LED-B2": "phosphor-converted blue",
    "LED-B3": "phosphor-converted blue", "LED-B4": "phosphor-converted blue",
    "LED-B5": "phosphor-converted blue", "LED-BH1": "hybrid: phosphor-converted blue and red",
    "LED-RGB1": "mixed red, green and blue", "LED-V1": "phosphor-converted violet",
    "LED-V2": "phosphor-converted violet",
}
for _key, _kind in LED_KIND.items():
    ILLUM_SOURCE[_key] = (f"CIE illuminant {_key} (white LED, {_kind}), CIE 015:2018 "
                          "(Colorimetry, 4th ed., doi:10.25039/TR.015.2018) tables of the LED illuminants")
# Tables written as colour ships them, in the order spectex lists them (shipped_illuminants()).
TABULATED = ["A"] + [f"FL{k}" for k in range(1, 13)] + list(LED_KIND)


def fmt_wl(w):
    w = float(w)
    return str(int(w)) if w.is_integer() else repr(w)


def write_table(name, source, obj_name, licence, wavelengths, columns, names):
    wl = np.asarray(wavelengths, dtype=float)
    assert np.all(np.diff(wl) > 0), name
    steps = np.unique(np.diff(wl))
    spacing = fmt_wl(steps[0]) if len(steps) == 1 else "irregular"
    lines = [
        f"# source: {source}",
        f"# {EXPORTER}",
        f"# colour-science object: {obj_name}",
        f"# range: {fmt_wl(wl[0])}-{fmt_wl(wl[-1])} nm, spacing {spacing} nm, {len(wl)} rows",
        f"# {licence}",
        ",".join(["wavelength"] + names),
    ]
    for i, w in enumerate(wl):
        lines.append(",".join([fmt_wl(w)] + [repr(float(c[i])) for c in columns]))
    with open(os.path.join(HERE, name), "w", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {name}: {len(wl)} rows, {fmt_wl(wl[0])}-{fmt_wl(wl[-1])} nm step {spacing}")


def read_csv(name):
    with open(os.path.join(HERE, name)) as f:
        rows = [l for l in f if not l.startswith("#")][1:]  # skip comments and header
    return np.array([[float(v) for v in r.split(",")] for r in rows])


def write_msds(name, source, obj_name, licence, msds, names):
    write_table(name, source, obj_name, licence, msds.wavelengths,
                [msds.values[:, k] for k in range(msds.values.shape[1])], names)


def write_sd(name, source, obj_name, licence, sd):
    write_table(name, source, obj_name, licence, sd.wavelengths, [sd.values], ["value"])


def write_daylight(key):
    """A CIE D illuminant from its 300-780 nm table, extended to 830 nm by the daylight formula.

    colour-science's D50, D55, D65 and D75 tables stop at 780 nm; CIE 015:2018 defines the D
    illuminants to 830 nm by the daylight formula S0 + M1 S1 + M2 S2 (S0, S1, S2 tabulated 300-830 nm).
    Grids that reach past 780 nm (e.g. 360:830) need those values: they are appended from
    colour.sd_CIE_illuminant_D_series at the illuminant's chromaticity (nominal CCT x 1.4388/1.4380),
    scaled by the ratio table/formula at 780 nm (1.0 up to 6e-6) so that the spectrum is continuous.
    """
    sd = colour.SDS_ILLUMINANTS[key]
    cct = DAYLIGHT_CCT[key] * 1.4388 / 1.4380
    formula = colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(cct))
    scale = sd[780] / formula[780]
    ext = np.arange(785, 831, 5, dtype=float)
    assert sd.wavelengths[-1] == 780 and formula.wavelengths[-1] == 830, key
    write_table(f"illuminant_{key}.csv",
                ILLUM_SOURCE[key] + "; 785-830 nm: CIE daylight formula (colour.sd_CIE_illuminant_D_series "
                f"at CCT {round(cct)} K), scaled by {scale!r} to join the table at 780 nm",
                f"colour.SDS_ILLUMINANTS['{key}'] + colour.sd_CIE_illuminant_D_series", CIE_LICENCE,
                np.concatenate([sd.wavelengths, ext]),
                [np.concatenate([sd.values, np.array([formula[w] * scale for w in ext])])], ["value"])


def main():
    for fname, key in [("observer_cie1931-2.csv", "CIE 1931 2 Degree Standard Observer"),
                       ("observer_cie1964-10.csv", "CIE 1964 10 Degree Standard Observer")]:
        write_msds(fname, CMFS_SOURCE, f"colour.MSDS_CMFS['{key}']", CIE_LICENCE,
                   colour.MSDS_CMFS[key], ["x", "y", "z"])

    for key in DAYLIGHT_CCT:
        write_daylight(key)
    for key in TABULATED:
        write_sd(f"illuminant_{key}.csv", ILLUM_SOURCE[key], f"colour.SDS_ILLUMINANTS['{key}']",
                 CIE_LICENCE, colour.SDS_ILLUMINANTS[key])

    basis = colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019
    write_msds("basis_mallett2019.csv",
               "Mallett & Yuksel, Spectral Primary Decomposition for Rendering with sRGB "
               "Reflectance, EGSR 2019, doi:10.2312/SR.20191216, supplementary data",
               "colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019",
               "licence: as redistributed in colour-science, BSD-3-Clause",
               basis, ["r", "g", "b"])

    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    sds = list(cc.values())
    wl = sds[0].wavelengths
    assert all(np.array_equal(s.wavelengths, wl) for s in sds)
    write_table("colorchecker_ohta.csv",
                "ColorChecker Classic reflectances measured by N. Ohta, The Basis of Color "
                "Reproduction Engineering (1997); same data as ISO 17321-1",
                "colour.SDS_COLOURCHECKERS['ColorChecker N Ohta']",
                "licence: measurement data as redistributed in colour-science, BSD-3-Clause",
                wl, [s.values for s in sds],
                [n.replace(" ", "_").replace(",", "") for n in cc])

    # Sanity checks, read back from the written files.
    cmf, d65, mb = (read_csv(n) for n in
                    ("observer_cie1931-2.csv", "illuminant_D65.csv", "basis_mallett2019.csv"))
    ybar555 = float(cmf[cmf[:, 0] == 555, 2][0])
    d65_560 = float(d65[d65[:, 0] == 560, 1][0])
    for key in list(DAYLIGHT_CCT) + TABULATED:  # every illuminant file reads back as colour ships it
        t = read_csv(f"illuminant_{key}.csv")
        sd = colour.SDS_ILLUMINANTS[key]
        assert np.array_equal(t[:len(sd.wavelengths), 0], sd.wavelengths), key
        assert np.array_equal(t[:len(sd.wavelengths), 1], sd.values), key
        assert np.all(np.diff(t[:, 0]) > 0) and np.all(t[:, 1] >= 0), key
        if key in DAYLIGHT_CCT or key == "A":  # CIE normalisation: 100 at 560 nm
            assert float(t[t[:, 0] == 560, 1][0]) == 100.0, key
    print(f"check: {len(DAYLIGHT_CCT) + len(TABULATED)} illuminants read back equal to colour's tables; "
          "D50, D55, D65, D75, A = 100.0 at 560 nm")
    sum_err = float(np.max(np.abs(mb[:, 1:].sum(axis=1) - 1.0)))
    assert np.array_equal(mb[:, 1:], basis.values)  # exact round trip
    print(f"check: CIE 1931 2deg ybar(555 nm) = {ybar555!r} (expect 1.0)")
    print(f"check: D65(560 nm) = {d65_560!r} (expect 100.0)")
    print(f"check: Mallett 2019 basis max|r+g+b-1| = {sum_err:.3e} (expect ~1e-5)")
    assert ybar555 == 1.0 and d65_560 == 100.0 and sum_err < 1e-4

if __name__ == "__main__":
    main()
