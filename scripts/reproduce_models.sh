#!/usr/bin/env bash
# Retrain every shipped model from scratch, evaluate it, train the direct-regression baseline, run the
# ablation, and rebuild docs/results.md and the packaged weights: the whole of docs/results.md from
# nothing, with the documented commands only.
#
#   scripts/reproduce_models.sh                 # everything (about 7 h on 2 CPU cores)
#   CATS="laptop mug" scripts/reproduce_models.sh
#   STEPS=200 CATS=mug WORK=/tmp/w scripts/reproduce_models.sh   # a quick smoke run
#
# Settings (environment): WORK (folder for data, runs and reports; default work/), CATS (categories),
# BASELINE_CATS (categories that also get the regression baseline), ABLATION_CAT (Table 3's category),
# STEPS / TRAIN_NUM / VAL_NUM (optimiser steps and views per model: default, each category's recipe
# below), TEST_NUM (test views), OOD_NUM (views of the OOD split; 0: none), DEVICE (auto/cpu/cuda),
# PACKAGE=0 to leave src/ucope/pretrained alone, RESULTS / REPORTS (the page and its slim reports). Every step resumes: finished data sets, runs and reports
# are kept, an interrupted training continues from its checkpoint.
#
# ROBUST_CATS (default: the ten shipped models that went through it) get the robustness stage after their recipe:
# 3,000 steps from that model with `--new-priors --augment 0.65` on 5,000 generator-2 views (lr 5e-4, x0.1 at 80 %;
# the dishwasher gentler: lr 2e-4, --augment 0.5). Every final run is then finished the same way (finish_run below):
# the surface noise of its validation views measured (scripts/set_denoise_default.py), its score calibrated
# (scripts/calibrate_scores.py), its pipeline chosen on validation views (scripts/choose_pipeline.py: which stages it
# keeps), its calibration fitted again on the chosen pipeline, and how much it searches chosen on the calibrated
# scores (scripts/choose_search.py: the sizes, the score bars and the restarts).
# (The shipped mug went through one more augmented stage of 3,000 steps before it; this script makes one.)
#
# ROUND2_CATS (default: eyeglasses scissors dishwasher drawer laptop laptop_rigid camera) get the second robustness
# stage of 2026-12-05 after that (round2_recipe below: more and stronger isotropic noise for the thin eyeglasses
# and scissors, a longer augmented stage for the dishwasher and the camera, more floor for the laptops, and the drawer's
# first one, from its generator-1 model to generator-2 views with new priors); the stage before it is kept as
# runs/CATEGORY_round1, and the calibration and refinement default are measured on the final model.
# ROUND3_CATS (default: dishwasher laptop camera drawer) get a third stage after it (round3_recipe; the second kept as
# runs/CATEGORY_round2). ROUND4_CATS (default: dishwasher) a fourth, the third's recipe again on data seed 5
# (round4_recipe; the third kept as runs/CATEGORY_round3), ROUND5_CATS (default: dishwasher) a fifth on data seed 8
# (round5_recipe; the fourth kept as runs/CATEGORY_round4).
set -euo pipefail
cd "$(dirname "$0")/.."

UCOPE=${UCOPE:-.venv/bin/ucope}
PY=${PY:-.venv/bin/python}
WORK=${WORK:-work}
CATS=${CATS:-"laptop mug eyeglasses drawer scissors dishwasher bottle bowl camera can laptop_rigid"}
BASELINE_CATS=${BASELINE_CATS-"laptop drawer camera mug"}  # empty: no baseline
ROBUST_CATS=${ROBUST_CATS-"mug camera laptop bowl bottle can laptop_rigid scissors eyeglasses dishwasher"}  # empty: none
ROUND2_CATS=${ROUND2_CATS-"eyeglasses scissors dishwasher drawer laptop laptop_rigid camera"}  # empty: none
ROUND3_CATS=${ROUND3_CATS-"dishwasher laptop camera drawer"}  # a third stage after the second (ROUND2_CATS only); empty: none
ROUND4_CATS=${ROUND4_CATS-"dishwasher"}  # a fourth stage after the third (ROUND3_CATS only); empty: none
ROUND5_CATS=${ROUND5_CATS-"dishwasher"}  # a fifth stage after the fourth (ROUND4_CATS only); empty: none
OOD_NUM=${OOD_NUM:-150}  # views (one per object) of the out-of-distribution split (held-out shape families, sizes 0.5-2x); 0: none
ROBUST_NUM=${ROBUST_NUM:-5000}
ABLATION_CAT=${ABLATION_CAT:-eyeglasses}
TEST_NUM=${TEST_NUM:-150}
DEVICE=${DEVICE:-auto}
PACKAGE=${PACKAGE:-1}
RESULTS=${RESULTS:-docs/results.md}
REPORTS=${REPORTS:-docs/reports}
TRAIN_ARGS=${TRAIN_ARGS:-"--batch-size 8 --lr 1e-3 --size slim --seed 0"}

# The recipe of each shipped model: "TRAIN_NUM STEPS VAL_NUM". laptop and mug: 4000 training views,
# 5000 steps (about 25 min each on 2 CPU threads); the other rigid categories and drawer 3000 views,
# 3000 steps; eyeglasses, dishwasher and scissors 3000 views, 4000 steps (these nine trained on 1 CPU
# thread each, two or three at a time on the 2-core machine). STEPS / TRAIN_NUM / VAL_NUM in the
# environment override every recipe. (The shipped dishwasher model was cut at 3489 of its 4000 steps by
# a --max-minutes 28 budget, after the learning-rate drop.)
recipe() {  # recipe CATEGORY
  local r
  case $1 in
    laptop|mug) r="4000 5000 200" ;;
    bottle|bowl|camera|can|laptop_rigid|drawer) r="3000 3000 100" ;;
    *) r="3000 4000 100" ;;
  esac
  set -- $r
  echo "${TRAIN_NUM:-$1} ${STEPS:-$2} ${VAL_NUM:-$3}"
}

# The learning rate drops x0.1 once 80% of the steps are done (--lr-step-epochs counts epochs of the
# training set: 0.8 * steps * batch 8 / training views).
lr_step_epochs() {  # lr_step_epochs CATEGORY
  read -r n steps _ <<<"$(recipe "$1")"
  awk -v s="$steps" -v n="$n" 'BEGIN { printf "%.3f", 0.8 * s * 8 / n }'
}

# Categories whose parts look alike (three identical drawers, mirror-image temples, two similar blades)
# hinge on segmentation: they train with the cross-entropy over points and a heavier segmentation term
# (a 1000-step drawer trial: validation segmentation accuracy 0.60 balanced / 0.2, 0.90 points / 1.0).
category_args() {  # category_args CATEGORY
  case $1 in
    drawer|eyeglasses|scissors) echo "--seg-weighting points --lambda-seg 1.0" ;;
    *) echo "" ;;
  esac
}

# Fine-tuning stages after the recipe's training, for the categories that were below the sanity bar
# (each stage on 1 CPU thread, two or three trainings sharing the 2-core machine: eyeglasses 22 + 29 +
# 10 min, drawer 31 + 34 min, camera 17 + 19 min; laptop_rigid 11 + 10 min alone on the machine; the model
# cards hold each stage's time):
# "VIEWS SEED STEPS LR" per stage (separated by ';'), each starting from the previous stage's model
# (`ucope train --init`) on a training set of its own (VIEWS views from data seed SEED), learning rate
# x0.1 at 80% of its steps. The last stage is the shipped model; the recipe's run is kept as
# CATEGORY_stage0, the others as CATEGORY_stageN. TRAIN_NUM / STEPS override the views / steps here too.
finetune_stages() {  # finetune_stages CATEGORY
  case $1 in
    eyeglasses) echo "6000 0 5000 5e-4;6000 1 5000 3e-4;4000 2 3000 2e-4" ;;
    drawer) echo "6000 0 6000 5e-4;6000 1 6000 3e-4" ;;
    camera|laptop_rigid) echo "6000 0 5000 5e-4;6000 1 5000 3e-4" ;;
    *) echo "" ;;
  esac
}

data() {  # data CATEGORY SPLIT NUM [SEED [FOLDER]]
  "$UCOPE" generate --category "$1" --split "$2" --num "$3" --seed "${4:-0}" --out "$WORK/data/${5:-$1_$2}" --workers 2 --quiet
}

finetune() {  # finetune CATEGORY RUN_NAME FROM_RUN DATA_FOLDER VIEWS STEPS LR
  local cat=$1 run="$WORK/runs/$2" from="$WORK/runs/$3" folder=$4 n=$5 steps=$6 lr=$7
  if [ -f "$run/model.json" ]; then return 0; fi
  local resume=""
  if [ -f "$run/checkpoint.json" ]; then resume="--resume"; fi
  # shellcheck disable=SC2086
  "$UCOPE" train --category "$cat" --data "$WORK/data/$folder" --val-data "$WORK/data/${cat}_val" \
    --out "$run" --init "$from" --steps "$steps" --lr-step-epochs "$(awk -v s="$steps" -v n="$n" 'BEGIN { printf "%.3f", 0.8 * s * 8 / n }')" \
    --device "$DEVICE" $TRAIN_ARGS --lr "$lr" $(category_args "$cat") --quiet $resume
}

train_category() {  # train_category CATEGORY [RUN_NAME]: the recipe, then its fine-tuning stages, into runs/RUN_NAME
  local c=$1 final=${2:-$1} stages prev i n seed steps lr name
  stages=$(finetune_stages "$c")
  if [ -z "$stages" ]; then
    train "$c" "$final"
    return 0
  fi
  train "$c" "${c}_stage0"
  IFS=';' read -ra st <<<"$stages"
  prev="${c}_stage0"
  for ((i = 1; i <= ${#st[@]}; i++)); do
    read -r n seed steps lr <<<"${st[i - 1]}"
    n=${TRAIN_NUM:-$n}
    steps=${STEPS:-$steps}
    name="${c}_stage$i"
    if [ "$i" -eq "${#st[@]}" ]; then name=$final; fi
    data "$c" train "$n" "$seed" "${c}_train_seed${seed}_$n"
    finetune "$c" "$name" "$prev" "${c}_train_seed${seed}_$n" "$n" "$steps" "$lr"
    prev=$name
  done
}

train() {  # train CATEGORY RUN_NAME [extra train args]
  local cat=$1 run="$WORK/runs/$2" steps; shift 2
  if [ -f "$run/model.json" ]; then return 0; fi
  read -r _ steps _ <<<"$(recipe "$cat")"
  local resume=""
  if [ -f "$run/checkpoint.json" ]; then resume="--resume"; fi
  # shellcheck disable=SC2086
  "$UCOPE" train --category "$cat" --data "$WORK/data/${cat}_train" --val-data "$WORK/data/${cat}_val" \
    --out "$run" --steps "$steps" --lr-step-epochs "$(lr_step_epochs "$cat")" --device "$DEVICE" $TRAIN_ARGS \
    $(category_args "$cat") --quiet $resume "$@"
}

robust_args() {  # the robustness stage's augmentation and learning rate of a category
  case $1 in dishwasher) echo "--augment 0.5 --lr 2e-4" ;; *) echo "--augment 0.65 --lr 5e-4" ;; esac
}

robust() {  # robust CATEGORY [OUT]: the robustness stage, runs/CATEGORY_prerobust -> runs/OUT (default CATEGORY), calibrated
  local c=$1 run="$WORK/runs/${2:-$1}" steps=${STEPS:-3000} resume=""
  if [ -f "$run/model.json" ] && grep -q '"calibration"' "$run/model.json"; then return 0; fi
  if [ -f "$run/model.json" ] && [ "${2:-$1}" != "$c" ]; then return 0; fi  # an intermediate stage: not calibrated
  data "$c" train "$ROBUST_NUM" 0 "${c}_train_robust"
  if [ ! -f "$run/model.json" ]; then
    if [ -f "$run/checkpoint.json" ]; then resume="--resume"; fi
    # shellcheck disable=SC2086
    "$UCOPE" train --category "$c" --data "$WORK/data/${c}_train_robust" --val-data "$WORK/data/${c}_val" --out "$run" \
      --init "$WORK/runs/${c}_prerobust" --new-priors $(robust_args "$c") --steps "$steps" \
      --lr-step-epochs "$(awk -v s="$steps" -v n="$ROBUST_NUM" 'BEGIN { printf "%.3f", 0.8 * s * 8 / n }')" \
      --batch-size 8 --device "$DEVICE" $(category_args "$c") --quiet $resume
  fi
  if [ "${2:-$1}" != "$c" ]; then return 0; fi  # a later stage follows: that one is calibrated
  finish_run "$c"
}

finish_run() {  # finish_run CATEGORY: runs/CATEGORY's noise threshold, calibration and pipeline, chosen on val views
  local c=$1 model="$WORK/runs/$1/model.json"
  if grep -q '"chosen_on": "val' "$model"; then return 0; fi
  "$PY" scripts/set_denoise_default.py --model "$model" --data "$WORK/data/${c}_val"
  "$PY" scripts/calibrate_scores.py --models "$WORK/runs/$c" --num "${CALIBRATE_NUM:-300}" --threads 1
  "$PY" scripts/choose_pipeline.py --model "$WORK/runs/$c" --report "$WORK/reports/${c}_val_pipeline.json"
  "$PY" scripts/calibrate_scores.py --models "$WORK/runs/$c" --num "${CALIBRATE_NUM:-300}" --threads 1
  "$PY" scripts/choose_search.py --model "$WORK/runs/$c" --report "$WORK/reports/${c}_val_pipeline.json"
}

# The second robustness stage (2026-12-05): "VIEWS STEPS LR" and the training options of each category, on
# VIEWS generator-2 views of data seed 3 (learning rate x0.1 at 80 % of the steps; 1 CPU thread each, the
# model cards hold the times: eyeglasses 21 min, scissors 20, dishwasher 21, drawer 56, laptop 16, two or
# three at a time; laptop_rigid 6.4 min alone on 2 threads; camera 22 min beside one other job).
round2_recipe() {  # round2_recipe CATEGORY
  case $1 in
    eyeglasses) echo "5000 4000 3e-4 --augment 0.65 --augment-set p_noise=0.5 noise_m=0.001,0.010 p_resample=0.45" ;;
    scissors) echo "5000 4000 3e-4 --augment 0.65 --augment-set p_noise=0.5 noise_m=0.001,0.010" ;;
    dishwasher|camera) echo "6000 5000 3e-4 --augment 0.65" ;;
    drawer) echo "8000 9000 5e-4 --augment 0.65 --new-priors" ;;
    laptop|laptop_rigid) echo "5000 3000 3e-4 --augment 0.65 --augment-set p_floor=0.6 floor_range=0.1,1.0" ;;
    *) echo "" ;;
  esac
}

# The third stage (2026-12-05, a second session): the dishwasher and the laptop with more floor and more
# resampled views on data seed 4 (dishwasher 21 min beside one other job; laptop 7.5 min alone on 2 threads).
# The camera's (2026-12-06): the second stage's recipe again on views of the camera generator's revision 2
# (half of the compacts ultra-compacts) of data seed 7 (13.5 min on 2 threads alone on the machine).
# The drawer's (2026-12-06, a twelfth session): 4,000 steps with new priors on views of the drawer generator's
# revision 2 (35 % of the nightstands and dressers on legs) of data seed 9 (28 min on 1 thread beside evaluations).
round3_recipe() {  # round3_recipe CATEGORY
  case $1 in
    dishwasher) echo "6000 4000 3e-4 --augment 0.65 --augment-set p_floor=0.6 floor_range=0.1,1.0 p_resample=0.45" ;;
    laptop) echo "5000 3000 2e-4 --augment 0.65 --augment-set p_floor=0.6 floor_range=0.1,1.0 p_resample=0.45" ;;
    camera) round2_recipe camera ;;
    drawer) echo "6000 4000 3e-4 --augment 0.65 --new-priors" ;;
    *) echo "" ;;
  esac
}

round3_seed() {  # round3_seed CATEGORY: the data seed of the third stage's views
  case $1 in camera) echo 7 ;; drawer) echo 9 ;; *) echo 4 ;; esac
}

# The fourth stage (2026-12-06): the dishwasher's third recipe again on fresh views of data seed 5 (26 min on
# 1 thread beside two other trainings). The same stage on views stretched 0.5-2x per axis (`ucope generate
# --stretch 0.5,2`, all or half of the instances) measured and not adopted (docs/results.md).
round4_recipe() {  # round4_recipe CATEGORY
  case $1 in
    dishwasher) round3_recipe dishwasher ;;
    *) echo "" ;;
  esac
}

# The fifth stage (2026-12-06, an eleventh session): the dishwasher's third recipe on views of the dishwasher
# generator's revision 2 (half of the integrated machines compact built-ins, 45 cm high) of data seed 8 (12 min on
# 2 threads).
round5_recipe() {  # round5_recipe CATEGORY
  case $1 in
    dishwasher) round3_recipe dishwasher ;;
    *) echo "" ;;
  esac
}

later_stage() {  # later_stage CATEGORY ROUND FROM_RUN OUT_RUN DATA_SEED: ROUND's recipe from runs/FROM_RUN to runs/OUT_RUN
  local c=$1 round=$2 from=$3 run="$WORK/runs/$4" seed=$5 n steps lr extra resume=""
  if [ -f "$run/model.json" ]; then return 0; fi
  read -r n steps lr extra <<<"$("${round}_recipe" "$c")"
  n=${TRAIN_NUM:-$n}
  steps=${STEPS:-$steps}
  data "$c" train "$n" "$seed" "${c}_train_${round}_$n"
  if [ -f "$run/checkpoint.json" ]; then resume="--resume"; fi
  # shellcheck disable=SC2086
  "$UCOPE" train --category "$c" --data "$WORK/data/${c}_train_${round}_$n" --val-data "$WORK/data/${c}_val" --out "$run" \
    --init "$WORK/runs/$from" --steps "$steps" --lr "$lr" \
    --lr-step-epochs "$(awk -v s="$steps" -v n="$n" 'BEGIN { printf "%.3f", 0.8 * s * 8 / n }')" \
    --batch-size 8 --threads 1 --device "$DEVICE" $(category_args "$c") $extra --quiet $resume
}

later_stages() {  # later_stages CATEGORY: runs/CATEGORY_round1 -> (round 2, 3, 4, 5) -> runs/CATEGORY, calibrated
  local c=$1 run="$WORK/runs/$1"
  if [ -f "$run/model.json" ] && grep -q '"calibration"' "$run/model.json"; then return 0; fi
  if [[ " $ROUND5_CATS " == *" $c "* && " $ROUND4_CATS " == *" $c "* && " $ROUND3_CATS " == *" $c "* ]]; then
    later_stage "$c" round2 "${c}_round1" "${c}_round2" 3
    later_stage "$c" round3 "${c}_round2" "${c}_round3" 4
    later_stage "$c" round4 "${c}_round3" "${c}_round4" 5
    later_stage "$c" round5 "${c}_round4" "$c" 8
  elif [[ " $ROUND4_CATS " == *" $c "* && " $ROUND3_CATS " == *" $c "* ]]; then
    later_stage "$c" round2 "${c}_round1" "${c}_round2" 3
    later_stage "$c" round3 "${c}_round2" "${c}_round3" 4
    later_stage "$c" round4 "${c}_round3" "$c" 5
  elif [[ " $ROUND3_CATS " == *" $c "* ]]; then
    later_stage "$c" round2 "${c}_round1" "${c}_round2" 3
    later_stage "$c" round3 "${c}_round2" "$c" "$(round3_seed "$c")"
  else
    later_stage "$c" round2 "${c}_round1" "$c" 3
  fi
  finish_run "$c"
}

evaluate() {  # evaluate MODEL CATEGORY REPORT_NAME SPLIT [extra eval args]: one report on the split's views
  local model=$1 cat=$2 rep="$WORK/reports/$3.json" split=$4; shift 4
  if [ -f "$rep" ]; then return 0; fi
  "$UCOPE" eval --model "$model" --data "$WORK/data/${cat}_$split" --out "$rep" --quiet "$@"
}

mkdir -p "$WORK/reports"
for c in $CATS; do
  read -r ntrain _ nval <<<"$(recipe "$c")"
  data "$c" train "$ntrain"
  data "$c" val "$nval"
  # the reported views: one per object, a seed of their own
  "$UCOPE" generate --category "$c" --split test --num "$TEST_NUM" --seed 2026 --views-per-instance 1 --out "$WORK/data/${c}_test" --workers 2 --quiet
  if [ "$OOD_NUM" -gt 0 ]; then
    "$UCOPE" generate --category "$c" --split ood --num "$OOD_NUM" --seed 2026 --views-per-instance 1 --out "$WORK/data/${c}_ood" --workers 2 --quiet
  fi
  final=$c
  if [[ " $ROUND2_CATS " == *" $c "* ]]; then final="${c}_round1"; fi
  if [[ " $ROBUST_CATS " == *" $c "* ]]; then
    train_category "$c" "${c}_prerobust"
    robust "$c" "$final"
  else
    train_category "$c" "$final"
  fi
  if [[ " $ROUND2_CATS " == *" $c "* ]]; then later_stages "$c"; fi
done
if [ "$PACKAGE" = 1 ]; then
  # shellcheck disable=SC2086
  "$PY" scripts/package_models.py --runs "$WORK/runs" --reports "$WORK/reports" --check-data "$WORK/data" --categories $CATS
fi
for c in $CATS; do  # test and ood: measured once, on the models as shipped (or as trained, PACKAGE=0)
  model="$WORK/runs/$c"
  if [ "$PACKAGE" = 1 ]; then model=$c; fi
  evaluate "$model" "$c" "${c}_test" test
  if [ "$OOD_NUM" -gt 0 ]; then evaluate "$model" "$c" "${c}_ood" ood; fi
done
if [ "$PACKAGE" = 1 ]; then
  # shellcheck disable=SC2086
  "$PY" scripts/package_models.py --figures-only --reports "$WORK/reports" --categories $CATS
fi
# The regression baselines: each starts from the voting model it is compared with (its encoder, segmentation and
# joint heads; `--init ... --head regression`), trains 3,000 more steps on that model's data and runs that model's
# stages with the regressed poses in place of the voted ones.
for c in $BASELINE_CATS; do
  init="$WORK/runs/$c"
  if [ "$PACKAGE" = 1 ]; then init=$c; fi
  train "$c" "${c}_regression" --init "$init" --head regression --steps "${STEPS:-3000}" --lr-step-epochs 3.84
  stages=$("$PY" -c "import ucope; print(','.join('regress_parts' if s == 'vote_parts' else s for s in ucope.Estimator.load('$init').pipeline.stages if s != 'align_faces'))")
  evaluate "$WORK/runs/${c}_regression" "$c" "${c}_regression" test --stages "$stages"
done
if [ -d "$WORK/runs/$ABLATION_CAT" ]; then  # Table 3, with the model as shipped (or as trained, PACKAGE=0)
  model="$WORK/runs/$ABLATION_CAT"
  if [ "$PACKAGE" = 1 ]; then model=$ABLATION_CAT; fi
  uncapped="vote_parts.options.max_axis_pairs=2147483647 vote_parts.options.centre.max_grid_pairs=2147483647"
  uncapped="$uncapped vote_parts.options.centre.max_refine_pairs=2147483647 vote_parts.options.axis.max_coarse_pairs=2147483647"
  uncapped="$uncapped vote_parts.options.axis.max_refine_pairs=2147483647"
  for n in 5000 10000 20000 40000; do
    evaluate "$model" "$ABLATION_CAT" "${ABLATION_CAT}_t3_pairs$n" test --pairs "$n"
    # shellcheck disable=SC2086
    evaluate "$model" "$ABLATION_CAT" "${ABLATION_CAT}_t3_pairs${n}_nocaps" test --pairs "$n" --set $uncapped
  done
  evaluate "$model" "$ABLATION_CAT" "${ABLATION_CAT}_t3_no_score_filter" test --set vote_parts.score_filter=false
  evaluate "$model" "$ABLATION_CAT" "${ABLATION_CAT}_t3_pairs_from_cloud" test --set vote_parts.segment_pairs=false
  evaluate "$model" "$ABLATION_CAT" "${ABLATION_CAT}_t3_no_awareness" test \
    --set vote_parts.score_filter=false vote_parts.segment_pairs=false vote_joints.awareness=false
fi
"$PY" scripts/make_results.py --reports "$WORK/reports" --out "$RESULTS"
