"""The fuel gauge of a config (no ROS): ideal (none), a coulomb counter (core/gauge.py) or a learning gauge
(core/learning_gauge.py), by the config's ``gauge: {model: ...}``."""
from battery_simulator.core.gauge import CoulombCounter
from battery_simulator.core.learning_gauge import LearningGauge


def make_gauge(config, true_capacity_ah, true_soc, model=None):
    """The gauge of a config: None for an ideal one (the truth is shown), a CoulombCounter, or a
    LearningGauge (it takes the pack ``model``'s tables as its own model of the pack)."""
    if not config or config.get('model', 'ideal') == 'ideal':
        return None
    if config.get('model') == 'learning':
        return LearningGauge(config, true_capacity_ah, true_soc, model)
    return CoulombCounter(config, true_capacity_ah, true_soc)
