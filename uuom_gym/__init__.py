"""UUOM-Gym: safety-aware speed control of underground overhead monorails.

Importing the package registers the environments with Gymnasium (``gym.make("UUOM-Track-v0")``); the string
``"uuom_gym:UUOM-Track-v0"`` works without a prior import.
"""

from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams

__version__ = "0.1.0"

from uuom_gym.registration import register_envs  # noqa: E402

register_envs()

__all__ = ["DEFAULT_VEHICLE", "G_MPS2", "VehicleParams", "__version__", "register_envs"]
