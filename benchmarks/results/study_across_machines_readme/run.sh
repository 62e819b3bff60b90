set -x
sudo -u postgres psql -c "CREATE USER optuna WITH PASSWORD 'PASSWORD'"
sudo -u postgres createdb --owner optuna optuna
export STORAGE=postgresql://optuna:PASSWORD@127.0.0.1:5432/optuna
for seed in 0 1; do
    sb3-reinforce-zoo train --algo reinforce --env CartPole-v1 -optimize --storage $STORAGE \
        --study-name reinforce-cartpole --max-total-trials 6 --n-trials 100 -n 20000 --n-evaluations 2 \
        --sampler random --no-optim-plots --num-threads 1 --seed $seed -f logs/worker$seed &
done
wait
sb3-reinforce-zoo train --algo reinforce --env CartPole-v1 -f logs/best --storage $STORAGE \
    --study-name reinforce-cartpole --trial-id 2
