#!/bin/bash
# The MuJoCo trajectory hashes (tests/data/trajectory_hashes.json, "/mujoco" entries) on a
# machine that has no simbridge install and no network, e.g. one with AVX-512 to check that
# neither step loop depends on the processor's BLAS/SIMD kernels. Runs, side by side:
# {compiled, Python loop} x {OpenBLAS's default core, OPENBLAS_CORETYPE=Haswell}; with DIAG=1
# also the Python loop with numpy's run-time SIMD off, with the machine's own numpy, and under
# OPENBLAS_CORETYPE=SkylakeX where the CPU has avx512f. Prints "x of 10 hashes equal the record"
# per run; the hashes go to $OUT/hashes.json.
#
# Prepare on a machine with network, in the repository root (.avx/ ignored via .git/info/exclude):
#   P="--platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform manylinux1_x86_64 --platform any"
#   for p in numpy==2.4.6 mujoco==4.0.0 mujoco-core==4.0.0 mujoco-studio==4.0.0 trimesh==5.2.0 \
#       yourdfpy==0.0.60 glfw==2.11.0 pyopengl==3.1.10 six==1.17.0 websockets==17.4; do
#     python3 -m pip download --no-deps --only-binary=:all: --python-version 3.12 --implementation cp $P -d .avx/whl $p; done
#   and a copy of pybullet_data under .avx/site/pybullet_data holding __init__.py and the files the
#   scenarios load (plane.urdf, r2d2.urdf, kuka_iiwa/, laikago/laikago_toes.urdf, mjcf/ant.xml and
#   their meshes/.mtl). The target needs python3 with pip and threadpoolctl, gcc, lxml.
# Run: DIAG=1 bash bench/avx512_hashes.sh   (PY, SITE, PKG, OUT, W override the defaults)
set -o pipefail
R=$PWD; A=$R/.avx
PY=${PY:-python3}; SITE=${SITE:-/tmp/site}; PKG=${PKG:-/tmp/pkg}; OUT=${OUT:-/tmp/avx-out}; W=${W:-/tmp/avx-work}
rm -rf "$W"; mkdir -p "$OUT" "$W"
t0=$(date +%s)
rm -rf "$SITE" "$SITE-np" "$PKG"
# numpy in a folder of its own, so that one run can use the machine's own numpy instead
$PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target "$SITE-np" "$A"/whl/numpy-*.whl || exit 1
$PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target "$SITE" $(ls "$A"/whl/*.whl | grep -v /numpy-) || exit 1
mkdir -p "$PKG/simbridge"
cp -r src/simbridge/. "$PKG/simbridge/"
cp -r backends "$PKG/simbridge/backends"
cp -r compare "$PKG/simbridge/compare"
cp -r robots "$PKG/simbridge/robots"
rm -f "$PKG"/simbridge/backends/mujoco/*.so
export PYTHONPATH=$PKG:$SITE-np:$SITE:$A/site${XPATH:+:$XPATH} PYTHONUNBUFFERED=1 PYTHONDONTWRITEBYTECODE=1
unset SIMBRIDGE_MUJOCO_STEP OPENBLAS_CORETYPE NPY_DISABLE_CPU_FEATURES
echo "== machine"; uname -m; $PY -V
grep -m1 'model name' /proc/cpuinfo; nproc
echo "avx512 flags: $(grep -o 'avx512[a-z_0-9]*' /proc/cpuinfo | sort -u | tr '\n' ' ')"
echo "compilers: $(which gcc cc 2>&1 | tr '\n' ' ')"
$PY - <<'PY'
import numpy, mujoco, sys
print("numpy", numpy.__version__, numpy.__file__)
print("mujoco", mujoco.__version__, mujoco.__file__)
from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
print("numpy dispatched SIMD:", [f for f in __cpu_dispatch__ if __cpu_features__.get(f)])
PY
# the compiled loop, as setup.py builds it (-O2 -std=c11 on the mujoco wheel's headers)
INC=$($PY -c 'import mujoco,os;print(os.path.join(os.path.dirname(mujoco.__file__),"include"))')
PYINC=$($PY -c 'import sysconfig;print(sysconfig.get_paths()["include"])')
EXT=$($PY -c 'import sysconfig;print(sysconfig.get_config_var("EXT_SUFFIX"))')
SO=$PKG/simbridge/backends/mujoco/_mjkernel$EXT
CC=${CC:-gcc}
echo "== build: $CC -fPIC -shared -fno-strict-aliasing -DNDEBUG -fwrapv -O2 -std=c11 -I$INC -I$PYINC -> $SO"
$CC -fPIC -shared -fno-strict-aliasing -DNDEBUG -fwrapv -O2 -std=c11 -I"$INC" -I"$PYINC" \
    backends/mujoco/_mjkernel.c -o "$SO" || echo "BUILD FAILED: only the Python loop is meaningful"
echo "setup $(( $(date +%s) - t0 )) s"

blas() {  # which OpenBLAS core numpy's BLAS picked under the current environment
  $PY -c 'import numpy, threadpoolctl, json
for i in threadpoolctl.threadpool_info():
    if i.get("internal_api")=="openblas": print(" ", i.get("filepath","").split("/")[-1], "core", i.get("architecture"), "threads", i.get("num_threads"))'
}
loopinfo() {
  $PY -c 'from simbridge.backends.mujoco import kernel as k; c=k.kernel_class(); print("  step loop:", "compiled" if c is not None else "Python ("+k.reason()+")")'
}
runone() {  # name loop coretype [NPY_DISABLE_CPU_FEATURES] [own-numpy]: hashes to $W/name.json, notes to $W/name.txt
  local name=$1 loop=$2 core=$3 npyoff=$4 ownnp=$5
  (
    [ -n "$ownnp" ] && export PYTHONPATH=${PYTHONPATH/$SITE-np:/}
    [ "$loop" = python ] && export SIMBRIDGE_MUJOCO_STEP=python
    [ -n "$core" ] && export OPENBLAS_CORETYPE=$core
    [ -n "$npyoff" ] && export NPY_DISABLE_CPU_FEATURES="$npyoff"
    echo "== $name (numpy $($PY -c 'import numpy;print(numpy.__version__)'); SIMBRIDGE_MUJOCO_STEP=${SIMBRIDGE_MUJOCO_STEP-} OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE-} NPY_DISABLE_CPU_FEATURES=${NPY_DISABLE_CPU_FEATURES-})"
    blas; loopinfo
    s=$(date +%s.%N)
    $PY -W error::simbridge.exceptions.SlowStepWarning ${T:-tests/_trajectory_hashes.py} --mujoco-only > "$W/$name.json" || echo "  FAILED rc=$?"
    echo "  $(python3 -c "print(f'{$(date +%s.%N)-$s:.1f} s')")"
    $PY - "$W/$name.json" <<'PY'
import json, sys
rec = {k: v for k, v in json.load(open("tests/data/trajectory_hashes.json"))["compiled"].items() if k.endswith("/mujoco")}
try:
    got = json.load(open(sys.argv[1]))
except Exception as e:
    print("  no hashes:", e); sys.exit()
same = [k for k in rec if got.get(k) == rec[k]]
print(f"  {len(same)} of {len(rec)} hashes equal the record; differ: {[k for k in rec if k not in same]}")
PY
  ) > "$W/$name.txt" 2>&1
}
NPYOFF=$($PY -c 'from numpy._core._multiarray_umath import __cpu_dispatch__ as d, __cpu_features__ as f; print(" ".join(x for x in d if f.get(x)))')
# side by side, one process each (the machine has the cores)
RUNS="compiled-default compiled-haswell python-default python-haswell"
runone compiled-default compiled "" & runone compiled-haswell compiled Haswell &
runone python-default python "" & runone python-haswell python Haswell &
if [ -n "$DIAG" ]; then
  RUNS="$RUNS python-npysimdoff python-ownnumpy"
  runone python-npysimdoff python "" "$NPYOFF" & runone python-ownnumpy python "" "" own &
  if grep -q avx512f /proc/cpuinfo; then RUNS="$RUNS python-skylakex"; runone python-skylakex python SkylakeX & fi
fi
wait
for r in $RUNS; do cat "$W/$r.txt"; done
$PY - "$W" $RUNS <<'PY'
import json, sys
w, runs = sys.argv[1], sys.argv[2:]
out = {}
for r in runs:
    try:
        out[r] = json.load(open(f"{w}/{r}.json"))
    except Exception as e:
        out[r] = f"no hashes: {e}"
json.dump(out, open(f"{w}/all.json", "w"), indent=1)
PY
cp "$W/all.json" "$OUT/hashes.json" 2>/dev/null
echo "total $(( $(date +%s) - t0 )) s"
