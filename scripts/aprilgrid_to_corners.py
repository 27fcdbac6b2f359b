#!/usr/bin/python3
"""Converts AprilGrid corner tracks (per-frame csv files of another detector, without images) into an
input for `fsp run --frontend corners` (docs/inputs.md, "External corners").

    scripts/aprilgrid_to_corners.py DATA OUT --extrinsics SENSOR_YAML

DATA holds cam0/<t_ns>.csv (one row per tag corner:
#ts,tag_rows,tag_cols,tag_size,tag_spacing,kp_x,kp_y,p_x,p_y,p_z,tag_id,corner_idx; kp in raw,
distorted pixels; corner_idx 0..3 at (0,0), (s,0), (s,s), (0,s) of the tag in the grid plane, which
is FSP's s1..s4), imu0.csv (#ts,wx,wy,wz,ax,ay,az) and config.yaml (cam0 intrinsics and radtan4
distortion, the IMU noise sigmas). The camera-to-IMU extrinsic is not in DATA: SENSOR_YAML is a
EuRoC cam0/sensor.yaml of the same sensor, whose T_BS is used.

OUT (created) becomes a EuRoC-layout folder without real images:
  OUT/mav0/cam0/data.csv       every frame time, each listing the one blank image data/blank.pgm
  OUT/mav0/cam0/sensor.yaml    intrinsics and distortion from config.yaml, T_BS from SENSOR_YAML
  OUT/mav0/imu0/data.csv       DATA/imu0.csv
  OUT/mav0/imu0/sensor.yaml    noise densities and random walks from config.yaml
  OUT/corners.csv              t_ns,object_id,u1,v1,...,u4,v4 (object id = tag id; a tag with fewer
                               than 4 corners detected in a frame is left out of that frame)
  OUT/objects.json             every tag id with class "tag"
then: fsp run OUT --frontend corners --corners OUT/corners.csv --objects OUT/objects.json --out RUN
"""
import argparse
import json
import os
import re
import shutil
import sys


def fail(msg):
    sys.exit("aprilgrid_to_corners.py: error: " + msg)


def yaml_list(text, key, path, section=None):
    """The numbers of `key: [a, b, ...]` (inside `section:` when given) in a YAML text."""
    if section is not None:
        m = re.search(r"^%s:\s*\n((?:[ \t]+.*\n?)*)" % re.escape(section), text, re.M)
        if not m:
            fail("%s: no section '%s'" % (path, section))
        text = m.group(1)
    m = re.search(r"^\s*%s:\s*\[([^\]]*)\]" % re.escape(key), text, re.M)
    if not m:
        fail("%s: no list '%s'" % (path, key if section is None else section + "." + key))
    try:
        return [float(v) for v in m.group(1).split(",")]
    except ValueError:
        fail("%s: '%s' is not a list of numbers" % (path, key))


def yaml_number(text, key, path, section):
    m = re.search(r"^%s:\s*\n((?:[ \t]+.*\n?)*)" % re.escape(section), text, re.M)
    n = m and re.search(r"^\s*%s:\s*([-+0-9.eE]+)\s*(#.*)?$" % re.escape(key), m.group(1), re.M)
    if not n:
        fail("%s: no number '%s.%s'" % (path, section, key))
    return float(n.group(1))


def read(path):
    try:
        with open(path) as f:
            return f.read()
    except OSError as e:
        fail("%s: %s" % (path, e.strerror))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", help="folder with cam0/<t_ns>.csv, imu0.csv, config.yaml")
    ap.add_argument("out", help="output folder (created)")
    ap.add_argument("--extrinsics", required=True,
                    help="EuRoC cam0/sensor.yaml of the same sensor (its T_BS is used)")
    args = ap.parse_args()

    config_path = os.path.join(args.data, "config.yaml")
    config = read(config_path)
    width, height = (int(v) for v in yaml_list(config, "resolution", config_path, "cam0"))
    intrinsics = yaml_list(config, "proj_params", config_path, "cam0")
    distortion = yaml_list(config, "dist_params", config_path, "cam0")
    if len(intrinsics) != 4 or len(distortion) != 4:
        fail("%s: cam0 needs 4 proj_params and 4 dist_params (pinhole, radtan4)" % config_path)
    noise = {name: yaml_number(config, key, config_path, "imu0")
             for name, key in [("gyroscope_noise_density", "sigma_g_c"),
                               ("gyroscope_random_walk", "sigma_gw_c"),
                               ("accelerometer_noise_density", "sigma_a_c"),
                               ("accelerometer_random_walk", "sigma_aw_c"),
                               ("rate_hz", "rate")]}
    T_BS = yaml_list(read(args.extrinsics), "data", args.extrinsics)
    if len(T_BS) != 16:
        fail("%s: T_BS data needs 16 numbers" % args.extrinsics)

    cam_dir = os.path.join(args.data, "cam0")
    try:
        names = sorted(n for n in os.listdir(cam_dir) if n.endswith(".csv"))
    except OSError as e:
        fail("%s: %s" % (cam_dir, e.strerror))
    frames, rows, tags = [], [], set()
    for name in names:
        t_ns = int(name[:-4]) if name[:-4].isdigit() else fail("%s: not a <t_ns>.csv name" % name)
        frames.append(t_ns)
        corners = {}  # tag id -> {corner index: (u, v)}
        path = os.path.join(cam_dir, name)
        for line_no, line in enumerate(read(path).splitlines(), 1):
            if not line.strip() or line.startswith("#"):
                continue
            f = line.split(",")
            if len(f) != 12:
                fail("%s:%d: expected 12 columns, got %d" % (path, line_no, len(f)))
            try:
                ts, u, v, tag, idx = int(f[0]), float(f[5]), float(f[6]), int(f[10]), int(f[11])
            except ValueError:
                fail("%s:%d: not a number" % (path, line_no))
            if ts != t_ns or idx not in range(4):
                fail("%s:%d: ts or corner_idx out of place" % (path, line_no))
            corners.setdefault(tag, {})[idx] = (u, v)
        for tag in sorted(corners):
            if len(corners[tag]) == 4:
                tags.add(tag)
                rows.append((t_ns, tag, [corners[tag][i] for i in range(4)]))
    if not frames:
        fail("%s: no <t_ns>.csv files" % cam_dir)

    mav0 = os.path.join(args.out, "mav0")
    os.makedirs(os.path.join(mav0, "cam0", "data"), exist_ok=True)
    os.makedirs(os.path.join(mav0, "imu0"), exist_ok=True)
    with open(os.path.join(mav0, "cam0", "data", "blank.pgm"), "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (width, height) + bytes(width * height))
    with open(os.path.join(mav0, "cam0", "data.csv"), "w") as f:
        f.write("#timestamp [ns],filename\n")
        f.writelines("%d,blank.pgm\n" % t for t in frames)
    with open(os.path.join(mav0, "cam0", "sensor.yaml"), "w") as f:
        f.write("%YAML:1.0\nsensor_type: camera\ncomment: converted by aprilgrid_to_corners.py\n")
        f.write("T_BS:\n  cols: 4\n  rows: 4\n  data: [%s]\n" % ", ".join(repr(v) for v in T_BS))
        f.write("rate_hz: 20\nresolution: [%d, %d]\ncamera_model: pinhole\n" % (width, height))
        f.write("intrinsics: [%s]\n" % ", ".join(repr(v) for v in intrinsics))
        f.write("distortion_model: radial-tangential\n")
        f.write("distortion_coefficients: [%s]\n" % ", ".join(repr(v) for v in distortion))
    try:
        shutil.copyfile(os.path.join(args.data, "imu0.csv"), os.path.join(mav0, "imu0", "data.csv"))
    except OSError as e:
        fail("%s: %s" % (e.filename, e.strerror))
    with open(os.path.join(mav0, "imu0", "sensor.yaml"), "w") as f:
        f.write("%YAML:1.0\nsensor_type: imu\n")
        f.writelines("%s: %r\n" % (k, v) for k, v in noise.items())
    with open(os.path.join(args.out, "corners.csv"), "w") as f:
        f.write("# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4\n")
        for t_ns, tag, c in rows:
            f.write("%d,%d,%s\n" % (t_ns, tag, ",".join("%.4f,%.4f" % uv for uv in c)))
    with open(os.path.join(args.out, "objects.json"), "w") as f:
        json.dump({"objects": [{"id": t, "class": "tag"} for t in sorted(tags)]}, f, indent=1)
    print("%s: %d frames, %d tag observations of %d tags" % (args.out, len(frames), len(rows),
                                                            len(tags)))


if __name__ == "__main__":
    main()
