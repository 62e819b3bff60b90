#!/usr/bin/env bash
# Take what `sb3-reinforce-zoo enjoy` needs of each trained agent (train.sh's output) into rl-trained-agents' layout:
# DEST/reinforce/<env>_1/<env>.zip (the run's final model, what enjoy loads), best_model.zip (the best of the zoo's
# evaluations during training, enjoy --load-best) and <env>/ (config.yml, args.yml, vecnormalize.pkl).
# Usage: copy.sh RUNS DEST ENV [ENV ...]
set -euo pipefail
runs=$1
dest=$2
shift 2
for env in "$@"; do
    src="$runs/reinforce/${env}_1"
    out="$dest/reinforce/${env}_1"
    mkdir -p "$out/$env"
    cp "$src/$env.zip" "$src/best_model.zip" "$out/"
    for f in config.yml args.yml vecnormalize.pkl; do
        if [ -f "$src/$env/$f" ]; then cp "$src/$env/$f" "$out/$env/"; fi
    done
    echo "$out: $(du -sh "$out" | cut -f1)"
done
