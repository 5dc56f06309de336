#!/usr/bin/env python3
"""York Urban Database (YUD) -> the calibration harness's truth.csv / labels.csv.

Reads a local copy of the York Urban Database (Denis, Elder, Estrada, ECCV 2008; the folder
`YorkUrbanDB` with `cameraParameters.mat`, `ECCV_TrainingAndTestImageNumbers.mat`,
`Manhattan_Image_DB_Names.mat` and one folder per image holding `<name>.jpg`,
`<name>LinesAndVP.mat`, `<name>GroundTruthVP_CamParams.mat` and
`<name>GroundTruthVP_Orthogonal_CamParams.mat`) and writes, for the images of one split, a
folder that test/test_calib_rooms.cpp reads through VBME_CALIB_ROOMS_DATA:

  <out>/<name>.jpg     symbolic links to the YUD images (nothing is copied)
  <out>/truth.csv      name,kind,width,height,f_px,cx,cy,k1,f35,r00,...,r22
  <out>/labels.csv     name,labelled,x_lines,y_lines,z_lines,x_len1,x_len2,...,z_len2

truth.csv: f_px = focal / pixelSize of cameraParameters.mat (one fixed camera for all images);
(cx, cy) = pp − 1 (MATLAB's first pixel is 1, the harness's 0); k1 = 0; f35 = f_px · 36 / width;
R's COLUMNS are the three ground-truth Manhattan directions in OpenCV camera axes (x right,
y down, z forward). YUD gives them as unit directions in a camera frame with y UP (the image
point is K · diag(1, −1, 1) · d), in `vp_orthogonal` of *GroundTruthVP_Orthogonal_CamParams.mat
(default, --gt orthogonal) or `vp` of *GroundTruthVP_CamParams.mat (--gt fitted, each direction
fitted to its lines alone, not exactly orthogonal); either is made exactly orthonormal here
(the nearest rotation, polar decomposition) and the largest change is reported.

labels.csv: per ground-truth direction (x, y, z = R's columns 0, 1, 2) the number of hand-
labelled segments of LinesAndVP.mat assigned to it (vp_association) and the two longest
lengths (px); labelled = 1 when every direction has at least --min-lines (2) segments.

Splits (--split): `test` and `train` are YUD's own (ECCV_TrainingAndTestImageNumbers.mat,
testSetIndex / trainingSetIndex into Manhattan_Image_DB_Names), `all` is every image,
`second-half` / `first-half` the images sorted by name and cut in two.

No third-party module is needed: the MAT-files (level 5) are read by the small reader below.

  python3 scripts/realdata/yud_to_truth.py /path/YorkUrbanDB /path/out --split test
"""
import argparse
import math
import os
import struct
import sys
import zlib

# ---------------------------------------------------------------- MAT-file level 5 reader

_NUM = {1: 'b', 2: 'B', 3: 'h', 4: 'H', 5: 'i', 6: 'I', 7: 'f', 9: 'd', 12: 'q', 13: 'Q', 16: 'B', 17: 'H',
        18: 'I'}


def _elements(buf, pos, end, e):
    """Yields (type, payload) of the data elements in buf[pos:end]."""
    while pos + 8 <= end:
        t, n = struct.unpack_from(e + 'II', buf, pos)
        if t >> 16:  # small data element: 2-byte size, 2-byte type, 4 bytes of data
            n, t = t >> 16, t & 0xFFFF
            yield t, buf[pos + 4:pos + 4 + n]
            pos += 8
            continue
        yield t, buf[pos + 8:pos + 8 + n]
        pos += 8 + n
        if t != 15:
            pos += (-n) % 8


def _numbers(t, data, e):
    if t not in _NUM:
        raise ValueError('MAT type %d not supported' % t)
    k = struct.calcsize(_NUM[t])
    return list(struct.unpack(e + _NUM[t] * (len(data) // k), data[:len(data) // k * k]))


class MatArray:
    """A numeric or char array (column-major values, dims) or a cell array (cells)."""

    def __init__(self, name, cls, dims, values=None, cells=None):
        self.name, self.cls, self.dims = name, cls, dims
        self.values, self.cells = values, cells

    def at(self, r, c):
        return self.values[r + c * self.dims[0]]

    def text(self):
        return ''.join(chr(int(v)) for v in self.values)


def _matrix(data, e):
    parts = list(_elements(data, 0, len(data), e))
    flags = _numbers(parts[0][0], parts[0][1], e)
    cls = flags[0] & 0xFF
    dims = _numbers(parts[1][0], parts[1][1], e)
    name = bytes(parts[2][1]).decode('latin-1')
    if cls == 1:  # cell
        return MatArray(name, cls, dims, cells=[_matrix(p, e) for t, p in parts[3:] if t == 14])
    if cls == 2:  # struct: not needed here
        return MatArray(name, cls, dims)
    if len(parts) < 4:
        return MatArray(name, cls, dims, values=[])
    return MatArray(name, cls, dims, values=_numbers(parts[3][0], parts[3][1], e))


def loadmat(path):
    """Returns {name: MatArray} of a level-5 MAT-file's top-level variables."""
    with open(path, 'rb') as f:
        buf = f.read()
    if len(buf) < 128 or buf[126:128] not in (b'IM', b'MI'):
        raise ValueError('%s: not a level-5 MAT-file' % path)
    e = '<' if buf[126:128] == b'IM' else '>'
    out = {}
    todo = [(buf, 128)]
    while todo:
        b, p = todo.pop()
        for t, payload in _elements(b, p, len(b), e):
            if t == 15:
                todo.append((zlib.decompress(payload), 0))
            elif t == 14:
                m = _matrix(payload, e)
                out[m.name] = m
    return out


# ---------------------------------------------------------------- 3×3 helpers (lists of rows)

def _mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def _det(a):
    return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
            a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
            a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))


def _inv(a):
    d = _det(a)
    c = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            m = [[a[r][s] for s in range(3) if s != j] for r in range(3) if r != i]
            c[j][i] = (-1) ** (i + j) * (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / d
    return c


def nearest_orthonormal(a):
    """The orthonormal matrix nearest to a (Frobenius): the polar factor, by Newton's
    iteration X <- (X + X^-T) / 2 (det keeps its sign)."""
    x = [row[:] for row in a]
    for _ in range(100):
        it = _transpose(_inv(x))
        y = [[(x[i][j] + it[i][j]) / 2 for j in range(3)] for i in range(3)]
        diff = max(abs(y[i][j] - x[i][j]) for i in range(3) for j in range(3))
        x = y
        if diff < 1e-15:
            break
    return x


def _angle(u, v):
    nu = math.sqrt(sum(x * x for x in u))
    nv = math.sqrt(sum(x * x for x in v))
    c = abs(sum(a * b for a, b in zip(u, v))) / (nu * nv)
    return math.degrees(math.acos(min(1.0, c)))


def _jpeg_size(path):
    with open(path, 'rb') as f:
        data = f.read()
    p = 2
    while p + 9 < len(data):
        if data[p] != 0xFF:
            p += 1
            continue
        m = data[p + 1]
        if m in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
            h, w = struct.unpack('>HH', data[p + 5:p + 9])
            return w, h
        if m in (0xD8, 0x01) or 0xD0 <= m <= 0xD7:
            p += 2
            continue
        p += 2 + struct.unpack('>H', data[p + 2:p + 4])[0]
    raise ValueError('%s: no JPEG frame header' % path)


# ---------------------------------------------------------------- conversion

def names_of(db, split):
    names = [c.text().strip() for c in loadmat(os.path.join(
        db, 'Manhattan_Image_DB_Names.mat'))['Manhattan_Image_DB_Names'].cells]
    names = [n.rstrip('/\\') for n in names]
    if split == 'all':
        return names
    if split in ('test', 'train'):
        s = loadmat(os.path.join(db, 'ECCV_TrainingAndTestImageNumbers.mat'))
        idx = s['testSetIndex' if split == 'test' else 'trainingSetIndex'].values
        return [names[int(i) - 1] for i in idx]
    srt = sorted(names)
    half = len(srt) // 2
    return srt[half:] if split == 'second-half' else srt[:half]


def convert(db, out, split, gt, min_lines, link):
    cam = loadmat(os.path.join(db, 'cameraParameters.mat'))
    f = cam['focal'].values[0] / cam['pixelSize'].values[0]
    cx, cy = cam['pp'].values[0] - 1, cam['pp'].values[1] - 1
    os.makedirs(out, exist_ok=True)
    truth = ['name,kind,width,height,f_px,cx,cy,k1,f35,' +
             ','.join('r%d%d' % (i, j) for i in range(3) for j in range(3))]
    labels = ['name,labelled,x_lines,y_lines,z_lines,x_len1,x_len2,y_len1,y_len2,z_len1,z_len2']
    worst = (0.0, '')
    nlab = 0
    for name in names_of(db, split):
        d = os.path.join(db, name)
        img = os.path.join(d, name + '.jpg')
        w, h = _jpeg_size(img)
        if gt == 'orthogonal':
            v = loadmat(os.path.join(d, name + 'GroundTruthVP_Orthogonal_CamParams.mat'))
            v = v['vp_orthogonal']
        else:
            v = loadmat(os.path.join(d, name + 'GroundTruthVP_CamParams.mat'))['vp']
        # columns: directions with y up -> OpenCV camera axes (y down)
        a = [[v.at(i, j) * (-1 if i == 1 else 1) for j in range(3)] for i in range(3)]
        for j in range(3):
            n = math.sqrt(sum(a[i][j] ** 2 for i in range(3)))
            for i in range(3):
                a[i][j] /= n
        r = nearest_orthonormal(a)
        for j in range(3):
            ch = _angle([a[i][j] for i in range(3)], [r[i][j] for i in range(3)])
            worst = max(worst, (ch, name))
        truth.append('%s.jpg,room,%d,%d,%.6f,%.6f,%.6f,0.000000,%.4f,%s' % (
            name, w, h, f, cx, cy, f * 36.0 / w,
            ','.join('%.9f' % r[i][j] for i in range(3) for j in range(3))))
        la = loadmat(os.path.join(d, name + 'LinesAndVP.mat'))
        lines, assoc = la['lines'], la['vp_association'].values
        lens = [[], [], []]
        for k, av in enumerate(assoc):
            if 1 <= int(av) <= 3:
                x1, y1 = lines.at(2 * k, 0), lines.at(2 * k, 1)
                x2, y2 = lines.at(2 * k + 1, 0), lines.at(2 * k + 1, 1)
                lens[int(av) - 1].append(math.hypot(x2 - x1, y2 - y1))
        for l in lens:
            l.sort(reverse=True)
            l.extend([0.0, 0.0])
        counts = [len(l) - 2 for l in lens]
        lab = all(c >= min_lines for c in counts)
        nlab += lab
        labels.append('%s.jpg,%d,%d,%d,%d,%s' % (
            name, lab, counts[0], counts[1], counts[2],
            ','.join('%.1f,%.1f' % (l[0], l[1]) for l in lens)))
        dst = os.path.join(out, name + '.jpg')
        if os.path.lexists(dst):
            os.remove(dst)
        if link:
            os.symlink(os.path.abspath(img), dst)
        else:
            with open(img, 'rb') as s, open(dst, 'wb') as o:
                o.write(s.read())
    with open(os.path.join(out, 'truth.csv'), 'w') as o:
        o.write('\n'.join(truth) + '\n')
    with open(os.path.join(out, 'labels.csv'), 'w') as o:
        o.write('\n'.join(labels) + '\n')
    print('%s: %d images (split %s, ground truth %s), %d labelled; f %.3f px, principal point '
          '(%.3f, %.3f); largest change of a direction made orthonormal: %.3f deg (%s)' % (
              out, len(truth) - 1, split, gt, nlab, f, cx, cy, worst[0], worst[1]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('yud', help='the YorkUrbanDB folder')
    ap.add_argument('out', help='output folder (created)')
    ap.add_argument('--split', default='test',
                    choices=['test', 'train', 'all', 'first-half', 'second-half'])
    ap.add_argument('--gt', default='orthogonal', choices=['orthogonal', 'fitted'])
    ap.add_argument('--min-lines', type=int, default=2)
    ap.add_argument('--copy', action='store_true', help='copy the images instead of linking')
    a = ap.parse_args()
    convert(a.yud, a.out, a.split, a.gt, a.min_lines, not a.copy)


if __name__ == '__main__':
    sys.exit(main())
