"""Which float32 arithmetic this machine's torch does: a fingerprint of a policy-sized network's outputs.

A trained policy's actions are float32 matrix products (MKL on x86). Their last bits depend on the code path the
library picks for the CPU (AVX2, AVX-512, the vendor), and a closed-loop episode turns those bits into a different
episode within a minute of driving: the shipped PPO policies, re-run on an AMD EPYC with AVX-512 (round 2, session
17), gave the committed trip time to 0.1 s on three of ten first held-out tracks and 37 % off on one. An episode of a
trained policy is therefore reproducible bit for bit only where the fingerprint is the same; evaluation records it
per episode (column ``float_path`` of ``episodes.csv``) so a check can tell a stale table from another CPU.
"""

from __future__ import annotations

import functools
import hashlib


@functools.lru_cache(maxsize=1)
def float_path_fingerprint() -> str:
    """``torch-<version>-<12 hex digits>``: the outputs of a fixed 16-64-64-1 tanh network (SB3's default policy
    shape) on fixed inputs, one sample per call as an evaluation feeds a policy, hashed."""
    import numpy as np
    import torch

    gen = np.random.default_rng(20261126)
    net = torch.nn.Sequential(torch.nn.Linear(16, 64), torch.nn.Tanh(), torch.nn.Linear(64, 64), torch.nn.Tanh(),
                              torch.nn.Linear(64, 1))
    with torch.no_grad():
        for p in net.parameters():
            p.copy_(torch.from_numpy(gen.normal(0.0, 0.5, tuple(p.shape)).astype(np.float32)))
        inputs = torch.from_numpy(gen.normal(0.0, 1.0, (64, 1, 16)).astype(np.float32))
        out = np.concatenate([net(x).numpy().ravel() for x in inputs])
    return f"torch-{torch.__version__}-{hashlib.sha256(out.tobytes()).hexdigest()[:12]}"


__all__ = ["float_path_fingerprint"]
