"""Controllers for UUOM-Track: stable-baselines3 agents and reference controllers."""
