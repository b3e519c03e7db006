"""The core on real recordings (read from <repo>/test/data/real):

- dual_lidar_scans_demo.bag: two real lidars on a standing robot, mount poses from
  test/data/real/README.md. Every valid point of each input must appear in the merged scan
  (within one bin and 1 cm) unless a closer point hides it, and every merged range must be a
  real input point.
- intel-corrected.log.gz (CARMEN): a scan moved by the real wheel odometry (through the core's
  odometry buffer and motion compensation) to the time of the next scan must agree with that
  next scan clearly better than the same scan left unmoved.
"""
import gzip
import math
import os

import numpy as np
import pytest

import merger_reference as ref
import multi_laserscan_merger_core as mlc

DATA = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'test', 'data', 'real'))
TOL = 0.01

OUT = dict(angle_min=-math.pi, angle_max=math.pi, angle_increment=math.pi / 720, range_min=0.0, range_max=30.0)
# robot -> scanner mounts, from test/data/real/README.md
MOUNTS = {
    'front_scanner': ref.yaw_matrix(0.23565, -0.0005, 0.06795, 0.0, 0.0, 0.0),
    'rear_scanner': ref.yaw_matrix(-0.23832, 0.00542, 0.09888, 0.0, 0.0, 3.141592),
}


# A footprint of that robot (output frame base_link, m): the lasers' centres sit on the long axis at
# x = +0.236 and -0.238, on the front and rear edges; a URG-class laser's housing is 50 mm wide, so
# the outline ends about 0.04 m past each centre (+-0.28 m). The mounts give no width: 0.40 m, a
# small indoor base; the nearest real return beside the robot is more than 0.5 m away.
FOOTPRINT = [[0.28, 0.2], [-0.28, 0.2], [-0.28, -0.2], [0.28, -0.2]]


def scan_dict(msg, range_min=None):
    return dict(stamp=msg.header.stamp.to_sec(), angle_min=msg.angle_min, angle_max=msg.angle_max,
                angle_increment=msg.angle_increment, time_increment=msg.time_increment,
                range_min=msg.range_min if range_min is None else range_min, range_max=msg.range_max,
                ranges=np.asarray(msg.ranges, np.float32), transform=MOUNTS[msg.header.frame_id])


def merged_points(out, merged):
    """(x, y) of every finite merged range, at its bin's direction."""
    k = np.nonzero(np.isfinite(merged))[0]
    a = out['angle_min'] + k * out['angle_increment']
    return merged[k] * np.cos(a), merged[k] * np.sin(a)


def merge_bag(out, trust_error_codes=False, every=3):
    """Merges the bag as publish_rate 0 does (every `every`-th output), checking each merge: every
    valid input point (outside the footprint, if any) is in the merged scan within one bin and
    1 cm or hidden by a closer point, and every merged range is an input point. Yields nothing;
    returns counters and the merged scans. trust_error_codes: the messages' range_min is replaced
    by 0, as if the driver's 0.006-0.019 m error codes were real readings."""
    rosbag = pytest.importorskip('rosbag')
    path = os.path.join(DATA, 'dual_lidar_scans_demo.bag')
    assert os.path.exists(path), path
    sources = [dict(name='front', topic='/front_scan'), dict(name='rear', topic='/rear_scan')]
    merger = mlc.Merger(out, sources)
    latest = [None, None]
    counts = dict(merges=0, points=0, hidden=0, hidden_same=0)
    results = []
    with rosbag.Bag(path) as bag:
        for i, (topic, msg, _) in enumerate(bag.read_messages(topics=['/front_scan', '/rear_scan'])):
            latest[0 if topic == '/front_scan' else 1] = scan_dict(msg, 0.0 if trust_error_codes else None)
            if None in latest or i % every:
                continue
            t_out = max(s['stamp'] for s in latest)  # publish_rate 0: the newest scan's stamp
            res = merger.merge(latest, t_out)
            assert res['status'] == ['used', 'used']
            merged = res['ranges'].astype(np.float64)
            results.append(merged)
            _, pts, _ = ref.reference_merge(out, sources, latest, t_out)
            for s, (bins, ranges) in enumerate(pts):
                other_k, other_r = pts[1 - s]
                for k, r in zip(bins, ranges):
                    near = [(k - 1) % 1440, k, (k + 1) % 1440]
                    found = [merged[j] for j in near if np.isfinite(merged[j])]
                    assert found and min(found) <= r + TOL, 'a point at bin %d, %.3f m is lost' % (k, r)
                    counts['points'] += 1
                    if any(abs(f - r) <= TOL for f in found):
                        continue
                    # Hidden: a closer point is there. Which source put it there?
                    d = np.abs(other_k - k)
                    d = np.minimum(d, 1440 - d)
                    if np.any((d <= 1) & (other_r < r - TOL)):
                        counts['hidden'] += 1
                    else:
                        # By another beam of the same lidar: seen from the robot's centre, a closer
                        # obstacle hides a farther one that the offset lidar saw beside it (parallax).
                        counts['hidden_same'] += 1
            all_k = np.concatenate([p[0] for p in pts])
            all_r = np.concatenate([p[1] for p in pts])
            for k in np.nonzero(np.isfinite(merged))[0]:
                d = np.abs(all_k - k)
                d = np.minimum(d, 1440 - d)
                assert np.any((d <= 1) & (np.abs(all_r - merged[k]) <= TOL)), 'bin %d holds no input point' % k
            assert len(merged) == 1441
            counts['merges'] += 1
    return counts, results


def test_dual_lidar_bag_every_point_kept():
    c, results = merge_bag(OUT)
    print('\ndual_lidar_scans_demo.bag: %d merges, %d valid input points: all kept or hidden; %d (%.1f%%) hidden '
          'by a closer point of the other lidar, %d (%.2f%%) by a closer point of the same lidar (parallax)'
          % (c['merges'], c['points'], c['hidden'], 100.0 * c['hidden'] / max(c['points'], 1), c['hidden_same'],
             100.0 * c['hidden_same'] / max(c['points'], 1)))
    assert c['merges'] > 100
    # The driver's error codes (0.006-0.019 m, below range_min 0.02) never become obstacles: the
    # nearest real return of the bag is 0.54 m from base_link.
    nearest = min(float(np.nanmin(np.where(np.isfinite(m), m, np.nan))) for m in results)
    assert nearest > 0.5, nearest


def test_dual_lidar_bag_footprint():
    out = dict(OUT, footprint=FOOTPRINT)
    c, results = merge_bag(out)
    plain, _ = merge_bag(OUT)
    # Every valid reading is outside this footprint: all of them are kept, as without it.
    assert c['points'] == plain['points'] and c['merges'] == plain['merges'] > 100
    for merged in results:
        x, y = merged_points(out, merged)
        assert not any(mlc.inside_polygon(FOOTPRINT, float(a), float(b)) for a, b in zip(x, y))

    # Trusting the error codes (range_min 0) puts them on the lasers, inside the footprint: the
    # filter drops them, and still keeps every reading outside (checked by merge_bag).
    trusted = dict(OUT, range_min=0.0)
    _, unfiltered = merge_bag(trusted, trust_error_codes=True, every=9)
    inside = sum(sum(mlc.inside_polygon(FOOTPRINT, float(a), float(b)) for a, b in zip(*merged_points(OUT, m)))
                 for m in unfiltered)
    assert inside > 100, 'the error codes must lie on the robot for this test to mean anything'
    c, filtered = merge_bag(dict(trusted, footprint=FOOTPRINT), trust_error_codes=True, every=9)
    for merged in filtered:
        x, y = merged_points(out, merged)
        assert not any(mlc.inside_polygon(FOOTPRINT, float(a), float(b)) for a, b in zip(x, y))
    print('\nfootprint: %d returns on the robot without it (error codes trusted), none with it; %d valid points '
          'outside kept' % (inside, c['points']))


def read_carmen(path):
    """FLASER: num r1..rn x y theta odom_x odom_y odom_theta timestamp hostname logger_timestamp.
    ODOM: x y theta tv rv accel timestamp hostname logger_timestamp. The ODOM line with
    timestamp 0 after each FLASER re-anchors the odometry to the corrected pose: skipped."""
    scans, odom = [], []
    previous = None
    with gzip.open(path, 'rt') as f:
        for line in f:
            w = line.split()
            if not w or w[0].startswith('#'):
                continue
            if w[0] == 'FLASER':
                n = int(w[1])
                ranges = np.array(w[2:2 + n], np.float32)
                ox, oy, oth, ts = (float(v) for v in w[5 + n:9 + n])
                scans.append(dict(t=ts, ranges=ranges, odom_pose=(ox, oy, oth), first_odom=len(odom)))
            elif w[0] == 'ODOM':
                ts = float(w[7])
                if not (ts == 0.0 and previous == 'FLASER'):
                    odom.append((ts, float(w[1]), float(w[2]), float(w[3])))
            if w[0] in ('FLASER', 'ODOM'):
                previous = w[0]
    return scans, odom


def carmen_scan(s):
    n = len(s['ranges'])
    # 180 beams, 1 degree apart, starting 90 degrees to the right; 81.83 m means no return.
    return dict(stamp=s['t'], angle_min=-math.pi / 2, angle_max=-math.pi / 2 + (n - 1) * math.pi / 180,
                angle_increment=math.pi / 180, time_increment=0.0, range_min=0.0, range_max=80.0,
                ranges=s['ranges'], transform=np.eye(4))


def to_points(ranges, out):
    k = np.nonzero(np.isfinite(ranges))[0]
    a = out['angle_min'] + k * out['angle_increment']
    return np.stack([ranges[k] * np.cos(a), ranges[k] * np.sin(a)], 1)


def median_nearest(a, b):
    if len(a) == 0 or len(b) == 0:
        return math.nan
    d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)).min(1)
    return float(np.median(d))


def test_carmen_odometry_moves_scan_onto_next():
    path = os.path.join(DATA, 'intel-corrected.log.gz')
    assert os.path.exists(path), path
    scans, odom = read_carmen(path)
    assert len(scans) == 910
    out = dict(angle_min=-math.pi, angle_max=math.pi, angle_increment=math.pi / 360, range_min=0.0, range_max=30.0)
    sources = [dict(name='laser', topic='scan', timeout=1e6)]
    merger = mlc.Merger(out, sources)
    moved, unmoved = [], []
    backwards = out_of_order = 0
    for k in range(len(scans) - 1):
        s0, s1 = scans[k], scans[k + 1]
        if s1['t'] <= s0['t']:
            backwards += 1  # the log's time goes backwards here: no motion to compensate
            continue
        buf = mlc.OdometryBuffer(200)
        # The odometry pose at the scan (the re-anchored one), then the wheel odometry until the next scan.
        x, y, th = s0['odom_pose']
        assert buf.add(s0['t'], (x, y, 0.0), ref.yaw_quat(th)) == 'added'
        for t, x, y, th in odom[s0['first_odom']:s1['first_odom']]:
            r = buf.add(t, (x, y, 0.0), ref.yaw_quat(th))
            out_of_order += r == 'out_of_order'
            assert r != 'rejected'
        scan0 = carmen_scan(s0)
        target = to_points(merger.merge([carmen_scan(s1)], s1['t'])['ranges'], out)
        with_odom = to_points(merger.merge([scan0], s1['t'], buf)['ranges'], out)
        without = to_points(merger.merge([scan0], s1['t'])['ranges'], out)
        moved.append(median_nearest(with_odom, target))
        unmoved.append(median_nearest(without, target))
    moved, unmoved = np.array(moved), np.array(unmoved)
    ok = np.isfinite(moved) & np.isfinite(unmoved)
    m_moved, m_unmoved = float(np.median(moved[ok])), float(np.median(unmoved[ok]))
    better = float(np.mean(moved[ok] < unmoved[ok]))
    print('\nintel-corrected.log: %d scan pairs (%d skipped: time goes backwards; %d odometry messages out of '
          'order ignored)\n  median point-to-nearest-point distance to the next scan: moved by odometry %.3f m, '
          'left unmoved %.3f m; moved is closer in %.0f%% of the pairs'
          % (ok.sum(), backwards, out_of_order, m_moved, m_unmoved, 100 * better))
    assert backwards == 4
    assert m_moved < 0.5 * m_unmoved
    assert better > 0.7
