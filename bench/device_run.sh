#!/usr/bin/env bash
# One prepared run of the GPU checks (issues 15 and 19) on a lent machine with an NVIDIA GPU,
# no network, its own python3 (docs/gpu.md says how the results were taken and where they went).
#
# Expects, beside the checkout: .whl/ (the wheels its python3 lacks: pyopencl, pytools,
# platformdirs, siphash24, OpenEXR, imagecodecs, trimesh) and shared/data (a copy of ../shared/data,
# linked as ../shared). Finds the driver's OpenCL library (libnvidia-opencl.so.1) and, without a
# vendor file for it, writes one (OCL_ICD_VENDORS). Then, each stage under a time limit and within
# DEADLINE seconds in all, its log and outputs under $RES, packed into $OUT/results.tgz after
# every stage (so a run cut short still returns what it did):
#   setup      devices and versions
#   tests      the core exactness tests on the GPU (pytest -n, OCLSHADE_DEVICE=nvidia)
#   record     bench/horizon_record.py (1024^2, 64 azimuths; RECORD_ARGS: more arguments, e.g. its
#              --variant KNOB=V; RECORD_LIMIT: its time limit, default 90 s)
#   tune       oclshade tune, one family at a time (full, not --quick); the user entry kept
#   quick      oclshade bench --quick
#   variants   bench/tuning_variants.py (the tuned default against every variant)
#   headlines  bench/headlines.py --no-saga
#   bench      oclshade bench (full sizes)
#   suite      the whole test suite (what time is left)
# Usage (repository root): bash bench/device_run.sh [stage ...]   (default: all, in that order;
# also tune:FAMILY[,FAMILY] (those families only), tests:FILE[,FILE] (those test files), tilesmem
# (bench/prototypes/gpu_tiles_rss.py: the resident memory of a --max-memory 200M run, tile by tile),
# profile (bench/prototypes/horizon_gpu_profile.py, PROFILE_ARGS its arguments: where a batched horizon
# frame's time goes), walk (bench/prototypes/horizon_walk_gpu.py, WALK_ARGS its arguments, WALK_LIMIT its
# time limit: the record's frame for variants of the walk's kernel and knobs))
set -u
OUT="${OUT:-/tmp/device-out}"
RES=/tmp/res
DEADLINE="${DEADLINE:-500}"
SPEC="${OCLSHADE_DEVICE:-nvidia}"
export OCLSHADE_DEVICE="$SPEC" PYTHONUNBUFFERED=1 PYTHONDONTWRITEBYTECODE=1 MPLBACKEND=Agg
mkdir -p "$OUT" "$RES"
T0=$(date +%s)
export PY="${PY:-python3}"

pack() { tar czf "$OUT/results.tgz" -C /tmp res 2>/dev/null; }
left() { echo $(( DEADLINE - ($(date +%s) - T0) )); }
# stage NAME LIMIT CMD...: runs CMD under min(LIMIT, time left), output to $RES/NAME.log
stage() {
  local name=$1 limit=$2; shift 2
  local remaining; remaining=$(left)
  if [ "$remaining" -lt 15 ]; then echo "=== $name: skipped (deadline)"; return 0; fi
  [ "$limit" -gt "$remaining" ] && limit=$remaining
  local t=$(date +%s)
  echo "=== $name (limit ${limit}s, $(left)s left)"
  timeout -k 5 "$limit" "$@" >"$RES/$name.log" 2>&1
  local rc=$?
  echo "=== $name rc=$rc in $(( $(date +%s) - t ))s"
  tail -n "${TAIL:-6}" "$RES/$name.log" | cut -c1-240
  pack
  return $rc
}

setup() {
  if [ -d .whl ] && ! $PY -c "import pyopencl" 2>/dev/null; then
    $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || return 1
  fi
  [ -e ../shared ] || { [ -d shared ] && ln -s "$PWD/shared" ../shared; }
  if [ "${OCL_ICD_VENDORS:-}" = /tmp/icd ]; then
    local lib
    lib=$(ls /usr/local/nvidia/lib64/libnvidia-opencl.so* /usr/lib/x86_64-linux-gnu/libnvidia-opencl.so* \
          /usr/lib64/libnvidia-opencl.so* /usr/local/nvidia/lib/libnvidia-opencl.so* 2>/dev/null | head -n 1)
    [ -n "$lib" ] || lib=$(find / -xdev -name 'libnvidia-opencl.so*' 2>/dev/null | head -n 1)
    echo "NVIDIA OpenCL library: ${lib:-not found}"
    mkdir -p /tmp/icd && echo "${lib:-libnvidia-opencl.so.1}" >/tmp/icd/nvidia.icd
    echo "OCL_ICD_VENDORS=/tmp/icd: $(cat /tmp/icd/nvidia.icd)"
  fi
}

if [ -d /tmp/site ]; then export PYTHONPATH="/tmp/site:$PWD"; else export PYTHONPATH="$PWD"; fi
if [ -z "${OCL_ICD_VENDORS:-}" ] && [ ! -e /etc/OpenCL/vendors/nvidia.icd ]; then export OCL_ICD_VENDORS=/tmp/icd; fi

facts() {
  nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm,clocks.mem --format=csv 2>&1
  grep -m1 'model name' /proc/cpuinfo; nproc
  $PY -c "import pyopencl as cl, numpy; print('pyopencl', cl.VERSION_TEXT, 'numpy', numpy.__version__)
for p in cl.get_platforms():
    for d in p.get_devices():
        print(p.name, '|', p.version, '|', d.name, '|', d.version, '|', d.driver_version, '| CUs', d.max_compute_units,
              '| image support', d.image_support, '| max wg', d.max_work_group_size)"
  $PY -m oclshade devices
}

CORE_TESTS="tests/test_shadows.py tests/test_packets.py tests/test_knobs.py tests/test_certificates.py
  tests/test_shadow_images.py tests/test_pyramid.py tests/test_horizon.py tests/test_svf.py tests/test_stability.py
  tests/test_curvature.py tests/test_terrain.py tests/test_screen_shadows.py tests/test_ssao.py tests/test_sunshine.py
  tests/test_sun_disc.py tests/test_shadow_volumes.py tests/test_reflect.py tests/test_envmap.py"

run_stage() {
  case $1 in
    setup) TAIL=20 stage setup 90 bash -c "$(declare -f setup facts); setup && export PYTHONPATH=/tmp/site:$PWD && facts" ;;
    tests) TAIL=12 OCLSHADE_NO_PROBE=1 stage tests 120 $PY -m pytest -q -p no:cacheprovider -n 16 -rfE $CORE_TESTS ;;
    tune|tune:*)
      local fams=${1#tune:}
      [ "$fams" = tune ] && fams="shadow pyramid horizon terrain ssao screen_shadows"
      for fam in ${fams//,/ }; do
        OCLSHADE_NO_PROBE=1 stage "tune_$fam" 60 $PY -m oclshade tune --family "$fam"
      done
      $PY -c "from oclshade.cachedir import tuning_dir; print(tuning_dir())" >"$RES/tuning_dir.txt" 2>&1
      cp -r "$(cat "$RES/tuning_dir.txt")" "$RES/tuning" 2>/dev/null; pack ;;
    tests:*) local files=${1#tests:}
      TAIL=12 OCLSHADE_NO_PROBE=1 stage tests_more 120 $PY -m pytest -q -p no:cacheprovider -n 16 -rfE ${files//,/ } ;;
    tilesmem) TAIL=30 stage tilesmem 40 $PY bench/prototypes/gpu_tiles_rss.py 200M ;;
    profile) TAIL=40 stage profile 90 $PY bench/prototypes/horizon_gpu_profile.py ${PROFILE_ARGS:-} --verbose-build --out "$RES/profile" ;;
    walk) TAIL=40 stage walk ${WALK_LIMIT:-200} $PY bench/prototypes/horizon_walk_gpu.py --device "$SPEC" ${WALK_ARGS:-} --out "$RES/walk.json" ;;
    quick) stage quick 90 $PY -m oclshade bench --quick --device "$SPEC" --out "$RES/bench_quick" ;;
    bench) stage bench 120 $PY -m oclshade bench --device "$SPEC" --out "$RES/bench_full" ;;
    record) stage record ${RECORD_LIMIT:-90} $PY bench/horizon_record.py --device "$SPEC" --reps 5 --samples ${SAMPLES:-60} \
              ${RECORD_ARGS:-} --out "$RES/record" ;;
    variants) stage variants 120 $PY bench/tuning_variants.py --no-saga --out "$RES/variants" ;;
    headlines) stage headlines 90 $PY bench/headlines.py --no-saga --reps 5 --out "$RES/headlines" ;;
    suite) TAIL=25 OCLSHADE_NO_PROBE=1 stage suite 900 $PY -m pytest -q -p no:cacheprovider -n 16 -rfE --timeout 120 ;;
    *) echo "unknown stage $1" >&2; return 2 ;;
  esac
}

for s in ${@:-setup tests record tune quick variants headlines bench suite}; do
  run_stage "$s"
  [ "$s" = setup ] && [ -d /tmp/site ] && export PYTHONPATH="/tmp/site:$PWD"
done
echo "=== done in $(( $(date +%s) - T0 ))s"
pack
