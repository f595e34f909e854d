#!/usr/bin/env python3
"""Methods rendered by Mitsuba 3 against the measured spectra rendered the same way.

    SPECTEX_BINARY=build/src/spectex SPECTEX_SOURCE_DIR=. \\
        build/venv/bin/python tests/bench/mitsuba_methods.py [OUT_DIR]

The 24 ColorChecker spectra of N. Ohta (colour-science's table) become 8-bit sRGB codes under D65
(colour-science's sRGB, clipped: one patch lies outside sRGB), laid out 6 x 4 in a 192 x 96 PNG and
baked with `--method basis` and `--method lattice` (float, every bit kept), and with bake's default
(no options: the LHTSS lattice in half with its precision budget, as a user's bake is), and given as
is to Mitsuba's own RGB `bitmap` texture (Mitsuba's upsampling, for comparison). The measured spectra are written as a
Fichet EXR of the same layout ("truth"). All are rendered exactly as tests/python/test_mitsuba.py
renders (the EXRs through python/spectex_mitsuba) (llvm_ad_spectral, uniform light, orthographic camera,
direct integrator, XYZ film, here 256 spp) under D65, A and FL11; patch means -> L*a*b* relative to
the light's white as rendered -> CIEDE2000 of each bake against the truth. A reported figure, never
a gate (docs/mitsuba.md).
"""
import os, sys, subprocess, tempfile, warnings
import numpy as np
warnings.filterwarnings('ignore')
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'python'))
import test_mitsuba as T  # noqa: E402  (its reader, reference integral and render)
import colour  # noqa: E402
import OpenImageIO as oiio  # noqa: E402
_scratch = None if len(sys.argv) > 1 else tempfile.TemporaryDirectory()
D = sys.argv[1] if len(sys.argv) > 1 else _scratch.name
os.makedirs(D, exist_ok=True)
sds = colour.SDS_COLOURCHECKERS['ColorChecker N Ohta']
names = list(sds.keys())
shape = colour.SpectralShape(380, 780, 5)
R = np.array([sds[n].copy().align(shape).values for n in names])  # 24 x 81
lams = np.arange(380, 781, 5.0)
xyz = np.array([colour.sd_to_XYZ(sds[n].copy().align(shape), illuminant=colour.SDS_ILLUMINANTS['D65']) for n in names]) / 100
codes = np.round(np.clip(colour.XYZ_to_sRGB(xyz), 0, 1) * 255).astype(np.uint8)
W, H = 192, 96
def layout(vals):
    img = np.zeros((H, W, vals.shape[1]), np.float32)
    for k in range(24):
        r, c = divmod(k, 6)
        img[r*24:(r+1)*24, c*32:(c+1)*32] = vals[k]
    return img
def write(path, img, chans=None, fmt=oiio.FLOAT):
    spec = oiio.ImageSpec(W, H, img.shape[2], fmt)
    if chans: spec.channelnames = tuple(chans); spec.attribute('spectralLayoutVersion', '1.0')
    o = oiio.ImageOutput.create(path); assert o.open(path, spec); o.write_image(img); o.close()
write(f'{D}/ohta.png', layout(codes.astype(np.float32)).astype(np.uint8), fmt=oiio.UINT8)
write(f'{D}/truth.exr', layout(R), [f'T.{int(l)}nm' for l in lams])
S = os.environ['SPECTEX_BINARY']
subprocess.run([S,'bake',f'{D}/ohta.png','-o',f'{D}/default.exr','-q'],check=True)
subprocess.run([S,'bake',f'{D}/ohta.png','-o',f'{D}/basis.exr','--type','float','--method','basis','-q'],check=True)
subprocess.run([S,'bake',f'{D}/ohta.png','-o',f'{D}/lattice.exr','--type','float','--method','lattice','-q'],check=True)
for light in ('D65','A','FL11'):
    il = T.illuminant(light)
    white = T.reference_xyz(lams, np.ones(81), il)[0]
    res = {}
    for f in ('truth','default','basis','lattice','mitsuba_rgb'):
        # mitsuba_rgb: Mitsuba's own `bitmap` texture of the PNG, which upsamples RGB its own way
        tex = {'type': 'bitmap', 'filename': f'{D}/ohta.png'} if f == 'mitsuba_rgb' else None
        img = T.render(f'{D}/{f}.exr', il, width=W, spp=256, texture=tex)  # film 192x96: patches 32x24 px
        out=[]
        for k in range(24):
            r,c=divmod(k,6)
            out.append(img[r*24+3:(r+1)*24-3, c*32+3:(c+1)*32-3].reshape(-1,3).mean(0))
        res[f] = colour.XYZ_to_Lab(np.array(out)/white[1], colour.XYZ_to_xy(white))
    for f in ('default','basis','lattice','mitsuba_rgb'):
        de = colour.delta_E(res['truth'], res[f], method='CIE 2000')
        print(f'{light:5s} {f:11s} dE00 mean {de.mean():.2f} max {de.max():.2f}')
