#!/usr/bin/env python3
r'''mrcal's Python on a .cameramodel that `lightprobe calib geometric` wrote.

Usage: mrcal_check.py MODEL REPORT_JSON [--uncertainty-factor F]

- the model loads and carries optimization_inputs whose intrinsics are the model's;
- mrcal's residuals at the stored state (optimizer_callback, nothing optimised) reproduce
  lightprobe's RMS reprojection error (REPORT_JSON's rms_px) to 1e-3 relative;
- mrcal.optimize() from the stored state lowers that RMS by less than 1e-3 relative (the
  state is the optimum of the stored problem, as mrcal-calibrate-cameras leaves it);
- the stored calobject_warp is the report's board_warp, and mrcal.optimize() moves it by
  less than 5 % of its reported standard deviation;
- with --uncertainty-factor: mrcal.projection_uncertainty (rays at infinity, worst
  direction) at the image centre and its median over a grid of pixels are finite and
  within a factor F of lightprobe's linear mean-frames estimate
  (uncertainty.linear_mean_frames_px), which is mrcal's method re-implemented.
When the model is the report's mrcal stand-in (the choice was Kannala-Brandt or Mei, which
mrcal has no model for: REPORT_JSON's mrcal_stand_in names the file), the RMS and the board
warp compared are the stand-in's: its rms_px, and a warp mrcal's optimum keeps (no reported
deviation: within 0.02 mm).
Prints the numbers; exits 1 on the first check that fails.
'''
import copy
import json
import sys

import numpy as np
import mrcal


def fail(msg):
    print(f"FAILED: {msg}")
    sys.exit(1)


model_path, report_path = sys.argv[1], sys.argv[2]
factor = float(sys.argv[4]) if len(sys.argv) > 4 and sys.argv[3] == '--uncertainty-factor' else None
report = json.load(open(report_path))
stand_in = report.get('mrcal_stand_in')
if stand_in is not None and stand_in.get('file') == model_path:
    print(f"the file is the stand-in {stand_in['lensmodel']} for the choice {report['lensmodel']}")
    report = dict(report, rms_px=stand_in['rms_px'], board_warp=None)
else:
    stand_in = None
m = mrcal.cameramodel(model_path)
oi = m.optimization_inputs()
if oi is None:
    fail(f"{model_path} has no optimization_inputs")
lensmodel, intrinsics = m.intrinsics()
if oi['lensmodel'] != lensmodel or not np.array_equal(oi['intrinsics'][0], intrinsics):
    fail("the optimization_inputs' intrinsics are not the model's")

# Residuals at the stored state. Corners lightprobe rejected carry weight -1; mrcal gives
# them zero residuals, so the RMS is over the inliers, per corner (2-D), as lightprobe's.
x = mrcal.optimizer_callback(**oi, no_jacobian=True, no_factorization=True)[1]
nboards = mrcal.num_measurements_boards(**oi)
inliers = np.count_nonzero(oi['observations_board'][..., 2] > 0)
rms = np.sqrt(np.sum(x[:nboards] ** 2) / inliers)
lp_rms = report['rms_px']
print(f"RMS: mrcal {rms:.6f} px, lightprobe {lp_rms:.6f} px over {inliers} inlier corners")
if not abs(rms - lp_rms) <= 1e-3 * lp_rms:
    fail(f"mrcal's RMS {rms} differs from lightprobe's {lp_rms} by more than 1e-3 relative")

again = copy.deepcopy(oi)
stats = mrcal.optimize(**again)
rms_again = np.sqrt(np.sum(stats['x'][:nboards] ** 2) / inliers)
print(f"mrcal.optimize from the stored state: RMS {rms_again:.6f} px")
if not rms_again >= rms * (1 - 1e-3):
    fail(f"the stored state is not the optimum: mrcal lowers the RMS from {rms} to {rms_again}")

# The board warp: stored as lightprobe fitted it, and mrcal's own optimum of the stored
# problem (mrcal.optimize updated `again` in place) within 5 % of its standard deviation.
if stand_in is not None and oi['do_optimize_calobject_warp']:
    moved = np.abs(again['calobject_warp'] - oi['calobject_warp'])
    print(f"calobject_warp: stored {oi['calobject_warp']} mm, after mrcal.optimize {again['calobject_warp']}")
    if not np.all(moved <= 0.02):
        fail(f"mrcal's optimum moves the stand-in's board warp by {moved} mm")
w = report.get('board_warp')
if w is not None:
    lp_w = np.array((w['x2_mm'], w['y2_mm']))
    cw = oi['calobject_warp']
    if cw is None or not oi['do_optimize_calobject_warp'] or not np.allclose(cw, lp_w, rtol=1e-12, atol=1e-12):
        fail(f"optimization_inputs' calobject_warp {cw} is not lightprobe's board warp {lp_w}")
    sd = np.array((w['x2_sd_mm'] or 0.02, w['y2_sd_mm'] or 0.02))  # splined models: no deviation
    moved = np.abs(again['calobject_warp'] - lp_w)
    print(f"calobject_warp: lightprobe {lp_w} mm (sd {sd}), after mrcal.optimize {again['calobject_warp']}")
    if not np.all(moved <= 0.05 * sd):
        fail(f"mrcal's optimum moves the board warp by {moved} mm, more than 5 % of its deviation {sd}")
elif stand_in is None and oi['do_optimize_calobject_warp']:
    fail("the report has no board warp (a flat board) but the optimization_inputs fit one")

if factor is not None:
    lp = report['uncertainty']['linear_mean_frames_px']
    W, H = m.imagersize()

    def sigma(q):
        v = mrcal.unproject(np.array(q, dtype=float), lensmodel, intrinsics)
        return mrcal.projection_uncertainty(v, m, atinfinity=True, what='worstdirection-stdev')

    centre = sigma(((W - 1) / 2., (H - 1) / 2.))
    grid = [sigma((x, y)) for x in np.linspace(0, W - 1, 12) for y in np.linspace(0, H - 1, 9)]
    grid = np.array([s for s in grid if np.isfinite(s)])
    median = np.median(grid)
    print(f"uncertainty at the centre: mrcal {centre:.4f} px, lightprobe {lp['centre_px']:.4f} px; "
          f"median: mrcal {median:.4f} px ({len(grid)} pixels), lightprobe {lp['median_px']:.4f} px")
    if not (np.isfinite(centre) and centre > 0 and len(grid) > 50):
        fail("mrcal's uncertainty is not finite")
    for name, a, b in (('centre', centre, lp['centre_px']), ('median', median, lp['median_px'])):
        if not (b > 0 and 1 / factor <= a / b <= factor):
            fail(f"{name}: mrcal {a} and lightprobe {b} differ by more than a factor {factor}")
print("PASSED")
