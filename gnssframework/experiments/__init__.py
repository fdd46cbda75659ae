"""Config-driven Monte Carlo comparisons (``gnssframework compare FILE``)."""

from .config import Candidate, Case, ComparisonConfig, Executor, load_config
from .runner import plan, run_comparison
from .scenarios import BatchResult, Scenario, get_scenario, register_scenario
from .scenarios import hooks as _core_scenarios  # noqa: F401 - imports (registers) the core's scenario kinds

__all__ = [
    "BatchResult",
    "Candidate",
    "Case",
    "ComparisonConfig",
    "Executor",
    "Scenario",
    "get_scenario",
    "load_config",
    "plan",
    "register_scenario",
    "run_comparison",
]
