"""Open a run's inspection files with the reference readers of their formats.

    python tests/readers/check_outputs.py RUN_DIR [RERUN_BIN]

run.rrd: the rerun-sdk 0.36.3 package's `rerun rrd verify`, then `rerun rrd print` for the
entities the recording promises, then every row of the wall's temperatures (rerun's RrdReader):
every laid point between ambient less 1 K and the highest peak in path.csv, the laid count never
falling, and the hottest-metal plot within the same bounds. run.mcap: the `mcap` reader with CRC checks; every message
validated against its channel's JSON schema (jsonschema), log times in order, zstd chunks, the
scenario metadata record. fields.h5: h5py and VTK's vtkHDFReader read back the temperature that
thermal.json states for its probe point; so does VTK's Xdmf2 reader (ParaView 5.11's "XDMF
Reader") through fields.xdmf, with every step. Exit 0 when every check holds; 1 with the failures.
"""

import json
import os
import re
import subprocess
import sys

import h5py
import jsonschema
from mcap.reader import make_reader

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def close(a, b):
    return abs(a - b) <= 1e-4 * max(1.0, abs(b))


RRD_ENTITIES = [
    "/world", "/world/part", "/world/plate", "/world/plan/spiral", "/world/plan/generators",
    "/world/torch", "/world/wall", "/world/deposited/0000", "/plots/preheat_c",
    "/plots/interpass_max_c", "/plots/power_w", "/plots/max_temperature_c", "/world/temperature",
    "/legend", "/events", "/__properties/scenario", "/viewport", "/time_panel",
]


def check_rrd(run, rerun):
    path = os.path.join(run, "run.rrd")
    v = subprocess.run([rerun, "rrd", "verify", path], capture_output=True, text=True)
    check(v.returncode == 0, f"rerun rrd verify {path}: {v.stderr.strip()[-200:]}")
    p = subprocess.run([rerun, "rrd", "print", path], capture_output=True, text=True)
    check(p.returncode == 0, "rerun rrd print reads the recording")
    entities = set(re.findall(r"^Chunk\(\S+\) with \d+ rows \([^)]*\) - (\S+) - ", p.stdout, re.M))
    for e in RRD_ENTITIES:
        check(e in entities, f"run.rrd has entity {e}")
    check("Blueprint" in p.stdout, "run.rrd carries a blueprint")


def highest_peak(run):
    import csv

    with open(os.path.join(run, "path.csv")) as f:
        return max(float(r["peak_c"]) for r in csv.DictReader(f))


def check_rrd_bounds(run):
    """Every value the recording shows for the wall is physical."""
    from rerun.experimental import RrdReader

    peak = highest_peak(run)
    lo, hi = 19.0, peak + 0.01
    rows, hottest = [], []
    for chunk in RrdReader(os.path.join(run, "run.rrd")).stream():
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if chunk.entity_path == "/world/temperature" and "temperature_c" in names:
            rows += zip(batch.column("sim_time").cast("int64").to_pylist(), batch.column("temperature_c").to_pylist())
        if chunk.entity_path == "/plots/max_temperature_c" and "Scalars:scalars" in names:
            hottest += [v for row in batch.column("Scalars:scalars").to_pylist() for v in row]
    rows.sort(key=lambda r: r[0])
    check(len(rows) > 1, f"run.rrd: {len(rows)} frames of /world/temperature")
    before, outside = 0, []
    for t, values in rows:
        if len(values) < before:
            check(False, f"run.rrd at {t} ns: {len(values)} laid after {before}")
        before = len(values)
        outside += [(t, i, v) for i, v in enumerate(values) if not lo <= v <= hi]
    check(not outside, f"run.rrd: every laid point in [{lo}, {hi:.2f}] °C in every frame {outside[:3]}")
    check(len(hottest) > len(rows), f"run.rrd: the hottest laid metal at {len(hottest)} steps")
    bad = [v for v in hottest if not lo <= v <= hi]
    check(not bad, f"run.rrd: the hottest laid metal within [{lo}, {hi:.2f}] °C {bad[:3]}")


MCAP_TOPICS = {
    "/part": "foxglove.SceneUpdate", "/plan": "foxglove.SceneUpdate",
    "/deposited": "foxglove.SceneUpdate", "/wall/temperature": "foxglove.PointCloud",
    "/tf": "foxglove.FrameTransform", "/torch": "foxglove.SceneUpdate",
    "/events": "foxglove.Log", "/plot/point": "waamtwin.PointResult",
    "/plot/field": "waamtwin.FieldSummary", "/plot/hottest": "waamtwin.Hottest",
}


def check_mcap(run):
    path = os.path.join(run, "run.mcap")
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        check(summary is not None, "run.mcap has a summary section")
        compressions = {c.compression for c in summary.chunk_indexes}
        check(compressions == {"zstd"}, f"run.mcap chunks are zstd ({compressions})")
        meta = [m for m in reader.iter_metadata() if m.name == "scenario"]
        check(len(meta) == 1 and "json" in meta[0].metadata, "run.mcap has the scenario metadata")
        validators, seen, last, count, bad = {}, {}, -1, 0, 0
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            count += 1
            if channel.id not in validators:
                check(schema.encoding == "jsonschema" and channel.message_encoding == "json",
                      f"{channel.topic}: JSON messages with a JSON schema")
                check(MCAP_TOPICS.get(channel.topic) == schema.name,
                      f"{channel.topic} carries {schema.name}")
                validators[channel.id] = jsonschema.Draft202012Validator(json.loads(schema.data))
            errors = list(validators[channel.id].iter_errors(json.loads(message.data)))
            if errors and bad < 5:
                check(False, f"{channel.topic} message {message.sequence}: {errors[0].message[:200]}")
            bad += bool(errors)
            if message.log_time < last:
                bad += 1
                check(False, f"{channel.topic} message {message.sequence} is out of log-time order")
            last = message.log_time
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
        check(bad == 0, f"all {count} MCAP messages valid and in log-time order")
        for topic in MCAP_TOPICS:
            check(seen.get(topic, 0) > 0 or topic == "/events", f"run.mcap has messages on {topic}")


def check_fields(run):
    path = os.path.join(run, "fields.h5")
    probe = json.load(open(os.path.join(run, "thermal.json")))["probe"]
    check(probe is not None, "thermal.json states a probe")
    with h5py.File(path, "r") as f:
        vtk_group = f["VTKHDF"]
        check(vtk_group.attrs["Type"] == b"UnstructuredGrid", "VTKHDF Type UnstructuredGrid")
        check(list(vtk_group.attrs["Version"]) == [2, 0], "VTKHDF Version 2.0")
        n = int(vtk_group["NumberOfPoints"][0])
        offsets = vtk_group["Steps/PointDataOffsets/temperature_c"]
        t = float(vtk_group["PointData/temperature_c"][offsets[probe["frame"]] + probe["point"]])
        check(close(t, probe["temperature_c"]),
              f"h5py: temperature {t:.4f} °C at the probe = simulation {probe['temperature_c']:.4f} °C")
        check(int(vtk_group["Steps"].attrs["NSteps"]) == len(vtk_group["Steps/Values"]), "NSteps")
        for name, ds in f["path"].items():
            check("unit" in ds.attrs, f"/path/{name} has a unit attribute")
        check(len(f["path/preheat_c"]) == n, "/path has one row per path point")

    import vtk

    reader = vtk.vtkHDFReader()
    reader.SetFileName(path)
    reader.UpdateInformation()
    steps = reader.GetOutputInformation(0).Get(vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    check(steps is not None and len(steps) > 1, f"vtkHDFReader sees {0 if steps is None else len(steps)} time steps")
    reader.UpdateTimeStep(probe["t_s"])
    out = reader.GetOutput()
    check(out.GetNumberOfPoints() == n and out.GetNumberOfCells() > 0, "vtkHDFReader reads the wall mesh")
    t = out.GetPointData().GetArray("temperature_c").GetValue(probe["point"])
    check(close(t, probe["temperature_c"]),
          f"vtkHDFReader: temperature {t:.4f} °C at the probe = simulation {probe['temperature_c']:.4f} °C")


def check_xdmf(run):
    """fields.xdmf, the form ParaView 5.11 reads with all its steps."""
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as pipeline
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader

    probe = json.load(open(os.path.join(run, "thermal.json")))["probe"]
    with h5py.File(os.path.join(run, "fields.h5"), "r") as f:
        n = int(f["VTKHDF/NumberOfPoints"][0])
        times = list(f["VTKHDF/Steps/Values"])
    reader = vtkXdmfReader()
    reader.SetFileName(os.path.join(run, "fields.xdmf"))
    reader.UpdateInformation()
    steps = reader.GetOutputInformation(0).Get(pipeline.TIME_STEPS())
    check(steps is not None and len(steps) == len(times),
          f"Xdmf2 reader sees {0 if steps is None else len(steps)} of {len(times)} time steps")
    reader.UpdateTimeStep(probe["t_s"])
    out = reader.GetOutputDataObject(0)
    check(out.GetNumberOfPoints() == n and out.GetNumberOfCells() > 0, "Xdmf2 reader reads the wall mesh")
    t = out.GetPointData().GetArray("temperature_c").GetValue(probe["point"])
    check(close(t, probe["temperature_c"]),
          f"Xdmf2 reader: temperature {t:.4f} °C at the probe = simulation {probe['temperature_c']:.4f} °C")


def main():
    run = sys.argv[1]
    rerun = sys.argv[2] if len(sys.argv) > 2 else "rerun"
    check_rrd(run, rerun)
    check_rrd_bounds(run)
    check_mcap(run)
    check_fields(run)
    check_xdmf(run)
    print(f"{len(failures)} failures")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
