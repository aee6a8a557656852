"""Other physics engines as independent plants (optional extras, imported lazily).

``forcecontrol.engines.mujoco``: MuJoCo (``pip install forcecontrol[mujoco]``).
"""

__all__: list[str] = []
