"""Controllers for UUOM-Track: stable-baselines3 agents, reference controllers, training and evaluation.

Modules
-------
controllers/        oracle minimum-time, rule-based, full-throttle and proportional controllers (one module each)
control_input       what a controller knows at one step, from the observation or the info dict
grade_check         model-free grade from the accelerometer (the controllers' and the shield's cross-check)
speed_profile       forward/backward minimum-time speed profile over a known track (``MinTimeProfile``)
shield              safety shield (command filter from the estimates and their uncertainty) and its env wrapper
residual            residual wrapper: the policy corrects the rule-based controller's command
ppo_lagrangian      PPO with a cost critic and a learned Lagrange multiplier (uses ``info["cost"]``)
demonstrations      the rule-based controller as demonstrator: replay-buffer seeding, online labels
demo_bc, ppo_bc     SAC with a Q-filtered BC term on demonstrations; PPO with a BC term on online labels
dagger              a PPO policy fitted to the rule-based controller by DAgger (a warm start for PPO)
training            ``train(TrainConfig)``: validation, checkpoints, Ctrl-C, resume (``uuom-train``)
hyperparameters     the rl-zoo style YAML files as training reads them (overrides, ``env_wrapper``)
checkpoints         crash-safe checkpoint directories; training_callbacks: their SB3 callbacks
evaluation          ``evaluate(EvalConfig)``: controllers x observers on held-out tracks (``uuom-evaluate``)
evaluation_table    per-episode rows -> summary table; evaluation_plots: its figures
cli                 the ``uuom-train`` / ``uuom-evaluate`` front ends
callbacks, metrics  TensorBoard safety scalars; per-episode summary used by training and evaluation
algos               algorithm names; ray_support: the optional Ray back end
hyperparams/        rl-baselines3-zoo style YAML files (ppo.yml, sac.yml, ppo-lag.yml)
"""
