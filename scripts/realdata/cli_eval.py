#!/usr/bin/env python3
"""Runs `vbme calibrate --auto` on every image of a harness folder (truth.csv, labels.csv, as
written by yud_to_truth.py) and measures it as test/test_calib_rooms.cpp does (focal error
|f/f_true - 1|; per true Manhattan direction the angle to the nearest estimated vanishing
point seen through the TRUE intrinsics; a refusal counts 100 % and 90 deg), so that options
the test does not vary can be measured: the true principal point (`--principal-point`, which
calibrateFrame() hands to Params::principal_point)
and the JPEG's own EXIF focal as the prior.

  python3 scripts/realdata/cli_eval.py build/apps/vbme/vbme /path/yud_all out.csv \
      [--pp truth|centre] [--exif] [--distortion] [--method global|ransac]
      [--subset /path/yud_test ...]

Writes one row per image to out.csv and prints the harness's summary lines for the folder,
its labelled images and every --subset folder's images.
"""
import argparse
import csv
import math
import os
import re
import subprocess
import sys
import tempfile


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def matrix(text, key):
    m = re.search(key + r':\s*!!opencv-matrix.*?data:\s*\[([^\]]*)\]', text, re.S)
    v = [float(x) for x in m.group(1).replace('\n', ' ').split(',')]
    return [v[0:3], v[3:6], v[6:9]]


def solve_k(f, cx, cy, p):  # K^-1 p
    return [(p[0] - cx * p[2]) / f, (p[1] - cy * p[2]) / f, p[2]]


def evaluate(t, text):
    K, R = matrix(text, 'K'), matrix(text, 'R')
    f = K[0][0]
    ft, cxt, cyt = float(t['f_px']), float(t['cx']), float(t['cy'])
    rt = [float(t['r%d%d' % (i, j)]) for i in range(3) for j in range(3)]
    dirs = []
    for b in range(3):
        r = [R[i][b] for i in range(3)]
        vp = [sum(K[i][k] * r[k] for k in range(3)) for i in range(3)]
        d = solve_k(ft, cxt, cyt, vp)
        n = math.sqrt(sum(x * x for x in d))
        dirs.append([x / n for x in d])
    errs = []
    for a in range(3):
        g = [rt[3 * i + a] for i in range(3)]
        errs.append(min(math.degrees(math.acos(min(1.0, abs(sum(x * y for x, y in zip(d, g))))))
                        for d in dirs))
    return f / ft - 1, errs


def percentile(v, q):
    v = sorted(v)
    pos = q * (len(v) - 1)
    i = int(pos)
    return v[i] + (pos - i) * (v[i + 1] - v[i]) if i + 1 < len(v) else v[-1]


def summary(name, rows):
    fe = [r['focal_err'] for r in rows]
    de = [d for r in rows for d in r['dir_err']]
    aa = [100 * sum(max(0.0, t - x) for x in de) / (t * len(de)) for t in (3, 5, 10)]
    print('%-22s focal error median %.2f %%, p75 %.2f %%, p90 %.2f %%; >10 %%: %d of %d; '
          'failed %d; AA@3/5/10 %.1f / %.1f / %.1f' % (
              name, 100 * percentile(fe, .5), 100 * percentile(fe, .75),
              100 * percentile(fe, .9), sum(x > 0.1 for x in fe), len(rows),
              sum(not r['ok'] for r in rows), aa[0], aa[1], aa[2]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('vbme')
    ap.add_argument('data')
    ap.add_argument('out')
    ap.add_argument('--pp', default='centre', choices=['centre', 'truth'])
    ap.add_argument('--exif', action='store_true', help='let the EXIF focal be the prior')
    ap.add_argument('--method', default='global', choices=['global', 'ransac'])
    ap.add_argument('--subset', action='append', default=[])
    ap.add_argument('--distortion', action='store_true', help='estimate k1 (--distortion k1)')
    a = ap.parse_args()
    truth = read_csv(os.path.join(a.data, 'truth.csv'))
    labels = {r['name']: r['labelled'] == '1' for r in read_csv(os.path.join(a.data, 'labels.csv'))}
    rows = []
    tmp = tempfile.mkdtemp(prefix='vbme_cli_eval_')
    for t in truth:
        cmd = [a.vbme, 'calibrate', '--image', os.path.join(a.data, t['name']), '--auto',
               '--method', a.method, '--out', os.path.join(tmp, 's.yml'), '--force', '-q']
        if not a.exif:
            cmd.append('--no-exif')
        if a.distortion:
            cmd += ['--distortion', 'k1']
        if a.pp == 'truth':
            cmd += ['--principal-point', '%s,%s' % (t['cx'], t['cy'])]
        p = subprocess.run(cmd, capture_output=True, text=True)
        r = {'name': t['name'], 'ok': p.returncode == 0, 'focal_err': 1.0, 'focal_rel': 0.0,
             'dir_err': [90.0] * 3}
        if r['ok']:
            with open(os.path.join(tmp, 's.yml')) as f:
                text = f.read()
            r['focal_rel'], r['dir_err'] = evaluate(t, text)
            m = re.search(r'\bk1:\s*([-+0-9.eE]+)', text)
            r['k1'] = float(m.group(1)) if m else 0.0
            r['focal_err'] = abs(r['focal_rel'])
        rows.append(r)
    with open(a.out, 'w') as o:
        o.write('name,ok,focal_err,focal_rel,k1,dir0,dir1,dir2\n')
        for r in rows:
            o.write('%s,%d,%.6f,%.6f,%.4f,%.4f,%.4f,%.4f\n' % (
                r['name'], r['ok'], r['focal_err'], r['focal_rel'], r.get('k1', 0.0),
                *r['dir_err']))
    tag = '%s pp=%s%s%s' % (a.method, a.pp, ' exif' if a.exif else '',
                            ' k1' if a.distortion else '')
    summary(tag, rows)
    summary(tag + ' labelled', [r for r in rows if labels.get(r['name'])])
    for s in a.subset:
        names = {t['name'] for t in read_csv(os.path.join(s, 'truth.csv'))}
        summary(tag + ' ' + os.path.basename(s.rstrip('/')), [r for r in rows if r['name'] in names])


if __name__ == '__main__':
    sys.exit(main())
