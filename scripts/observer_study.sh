#!/bin/bash
# The per-observer study of docs/rl.md §9: for each OBSERVER:SEED, train a bare PPO policy in the speed-target
# set-up (skipped when runs/obs/span13_<observer>_s<seed>/model.zip exists, e.g. copied from the shipped
# results/agents/observer_study_ppo/policies/<observer>_s<seed>), evaluate it with its observer on the 100 held-out
# tracks, then merge everything with the oracle and rule-based reference, one pooled row per observer.
#
#   scripts/observer_study.sh oracle:0 oracle:1 oracle:2 sf-kf:0 ...     # 10-12 min per pair on 2 idle cores
#   EXTRA_MERGE="results/rl/eval_span" OUT=/tmp/study scripts/observer_study.sh ...  # more folders to merge; output
set -euo pipefail
cd "$(dirname "$0")/.."
KW='{"action_mode": "speed_target", "speed_target_cap": "station", "speed_tracker": {"integral_clamp_m": 2.0}, "speed_target_range": [0.8, 1.3]}'
parts=(${EXTRA_MERGE:-})
declare -A members
for job in "$@"; do
  obs=${job%:*}; seed=${job#*:}
  run=runs/obs/span13_${obs}_s${seed}
  [ -f $run/model.zip ] || python -m scripts.train --algo ppo --residual 0 --no-shield --observer $obs --timesteps 300000 \
      --seed $seed --n-envs 2 --eval-freq 0 --checkpoint-freq 100000 --no-progress --env-kwargs "$KW" --run-dir $run
  [ -f ${run}_eval/summary.csv ] || python -m scripts.evaluate --controllers $run --observers $obs --episodes 100 \
      --workers 2 --env-kwargs "$KW" --out ${run}_eval --quiet
  parts+=(${run}_eval)
  members[$obs]="${members[$obs]:+${members[$obs]},}span13_${obs}_s${seed}"
done
[ -f runs/obs/reference/summary.csv ] || python -m scripts.evaluate --controllers oracle rule-based \
    --observers dffrls-aekf --episodes 100 --workers 2 --out runs/obs/reference --quiet
pools=()
for obs in "${!members[@]}"; do
  [[ ${members[$obs]} == *,* ]] && pools+=(--pool "span13 ($obs)=${members[$obs]}")
done
python -m scripts.evaluate --merge runs/obs/reference "${parts[@]}" "${pools[@]}" --controllers oracle rule-based \
    --workers 2 --out "${OUT:-results/agents/observer_study_ppo}" --quiet
