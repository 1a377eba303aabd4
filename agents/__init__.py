"""Controllers for UUOM-Track: stable-baselines3 agents and reference controllers.

Modules
-------
controllers    oracle minimum-time controller, rule-based controller, observation/info decoding
speed_profile  forward/backward minimum-time speed profile over a known track
shield         safety shield (command filter from the estimates and their uncertainty) and its env wrapper
ppo_lagrangian PPO with a cost critic and a learned Lagrange multiplier (uses ``info["cost"]``)
callbacks      TensorBoard scalars of safety and performance during training
metrics        per-episode summary (success, trips, violations per km, cost rate, trip time, energy)
algos          algorithm names of ``scripts/train.py``
hyperparams/   rl-baselines3-zoo style YAML files (ppo.yml, sac.yml, ppo-lag.yml)
"""
