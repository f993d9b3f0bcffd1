#!/usr/bin/env bash
# Usage: register-matches-command.sh XPOSE PYTHON SOURCE_DIR WORK_DIR
# Simulated phantom X-rays registered by `xpose register` and by Examples/Python/register.py (the
# filter pipeline): both must report the same misalignment and correction to 1e-6, and the same
# status. Then by the command from a given start and by the Python session
# (xpose.vtkXPRegistrationSession) from the same files and options: one session code, so the same
# record (timings apart) and the same result folder's files.
set -euo pipefail
xpose=$1 python=$2 source=$3 work=$4
geometry=$source/Data/geometry/stereo-oblique-90.json
rm -rf "$work" && mkdir -p "$work"
"$xpose" phantom --out "$work/ct" --spacing 2 >/dev/null
"$xpose" simulate --ct "$work/ct" --geometry "$geometry" --pose 3,-2,1,1,-1,1.5 --noise 20 --kv-contrast \
  --out-dir "$work/xray" >/dev/null
"$xpose" register --ct "$work/ct" --geometry "$geometry" --xray "$work/xray/xray_A.png" --xray "$work/xray/xray_B.png" \
  --size 256x192 --out-dir "$work/command" >/dev/null
"$python" "$source/Examples/Python/register.py" --ct "$work/ct" --geometry "$geometry" \
  --xray "$work/xray/xray_A.png" --xray "$work/xray/xray_B.png" --size 256x192 >"$work/python.json"
"$python" - "$work/command/result.json" "$work/python.json" <<'PY'
import json, sys
command, python = (json.load(open(path)) for path in sys.argv[1:3])
def numbers(pose):
    return pose["translation_mm"] + [pose["rotation_deg"][a] for a in ("pitch", "roll", "yaw")]
worst = max(abs(a - b) for key in ("misalignment", "correction")
            for a, b in zip(numbers(command[key]), numbers(python[key])))
print("status", command["status"], python["status"], "largest difference", worst)
print("misalignment", numbers(python["misalignment"]))
sys.exit(0 if command["status"] == python["status"] == "ok" and worst <= 1e-6 else 1)
PY
"$xpose" register --ct "$work/ct" --geometry "$geometry" --xray "$work/xray/xray_A.png" --xray "$work/xray/xray_B.png" \
  --size 256x192 --initial-pose 1,0,0,0,0,0 --couch 4dof --target 10,-20,30 --action-level-mm 1 --action-level-deg 1 \
  --max-uncorrected-deg 2.5 --out-dir "$work/command-from-start" >/dev/null || test $? -eq 3
"$python" - "$work" "$geometry" <<'PY'
import json, os, sys
import xpose
work, geometry = sys.argv[1:3]
session = xpose.vtkXPRegistrationSession()
session.SetCTPath(f"{work}/ct")
session.SetGeometryPath(geometry)
session.AddXRayPath(f"{work}/xray/xray_A.png")
session.AddXRayPath(f"{work}/xray/xray_B.png")
session.SetSize("256x192")
session.SetInitialPose(1, 0, 0, 0, 0, 0)
session.SetCouch("4dof")
session.SetTarget("10,-20,30")
session.SetActionLevels(1, 1)
session.SetMaxUncorrected(float("inf"), 2.5)
status = session.Run()
if status < 0:
    sys.exit("session refused: " + session.GetLastError())
if not session.WriteResultFolder(f"{work}/python"):
    sys.exit("session could not write: " + session.GetLastError())
# A refused input says which file, and leaves nothing to write.
refused = xpose.vtkXPRegistrationSession()
refused.GlobalWarningDisplayOff()
refused.SetCTPath(f"{work}/no-such-ct")
refused.SetGeometryPath(geometry)
refused.AddXRayPath(f"{work}/xray/xray_A.png")
assert refused.Run() == -1 and "no-such-ct" in refused.GetLastError(), refused.GetLastError()
assert refused.GetResultJSON() == "" and not refused.WriteResultFolder(f"{work}/refused")
# A device that is no device is refused by name, before any file is read.
refused.SetDevice("gpu")
assert refused.Run() == -1 and "--device" in refused.GetLastError(), refused.GetLastError()
# So is a schedule that is no schedule.
refused.SetDevice("cpu")
refused.SetSchedule("fast")
assert refused.Run() == -1 and "--schedule" in refused.GetLastError(), refused.GetLastError()
# And a couch that is no couch.
refused.SetSchedule("standard")
refused.SetCouch("5dof")
assert refused.Run() == -1 and "--couch" in refused.GetLastError(), refused.GetLastError()
# Choosing between the CT with its table and the body alone, and taking the body alone, at once.
both = xpose.vtkXPRegistrationSession()
both.GlobalWarningDisplayOff()
both.SetCTPath(f"{work}/ct")
both.SetGeometryPath(geometry)
both.AddXRayPath(f"{work}/xray/xray_A.png")
both.AddXRayPath(f"{work}/xray/xray_B.png")
both.SetSize("256x192")
both.SetRemoveTable(True)
both.SetChooseTable(True)
assert both.Run() == -1 and "--choose-table" in both.GetLastError(), both.GetLastError()
# Keeping the table registers the CT as given: no choice in the record; false restores the choice.
both.SetKeepTable(True)
assert both.Run() >= 0, both.GetLastError()
assert "table" not in json.loads(both.GetResultJSON()), "--keep-table still chose"
both.SetKeepTable(False)
assert both.Run() >= 0 and "table" in json.loads(both.GetResultJSON()), both.GetLastError()

def without_times(record):
    record.pop("timing_s")
    for stage in record["convergence"]["stages"]:
        stage.pop("seconds")
    return record
command = without_times(json.load(open(f"{work}/command-from-start/result.json")))
python = without_times(json.loads(session.GetResultJSON()))
written = without_times(json.load(open(f"{work}/python/result.json")))
print("status", command["status"], python["status"], "misalignment", python["misalignment"])
assert python == written, "the written result.json differs from the session's record"
differences = sorted(k for k in command if command[k] != python.get(k))
assert not differences, f"the session's record differs from the command's in {differences}"
assert (status == 1) == (command["status"] == "ok")
if status == 1:  # the couch block: a 4-DOF couch leaves pitch and roll, and names why
    assert python["couch"]["motions"] == ["lateral", "longitudinal", "vertical", "yaw"], python["couch"]
    assert python["couch"]["rotation_deg"]["pitch"] == 0 and "no_pitch" in python["couch"]["limited_by"], python["couch"]
    assert python["couch"]["target_ct"] == [10, -20, 30], python["couch"]
names = sorted(os.listdir(f"{work}/command-from-start"))
assert names == sorted(os.listdir(f"{work}/python")), names
for name in names:
    if name.endswith(".png"):
        assert open(f"{work}/command-from-start/{name}", "rb").read() == open(f"{work}/python/{name}", "rb").read(), name
PY
