"""Perfect-foresight reference controllers (issue 29): the storage oracle as a linear program solved with HiGHS
(highspy), its replay in the environment, and receding-horizon MPC over the same LP builder.

Modules: ``plant`` reads the env's storage problem (typed config + episode series), ``lp`` builds the sparse LP,
``solver`` solves it with highspy (imported there only, lazily), ``oracle`` iterates the battery efficiencies to
their fixed point and assembles the schedule, ``polish`` improves it on the batteries' marginal efficiencies,
``relax`` is the relaxation behind the certified lower bound, ``lockstep`` merges scaled-copy batteries for the
district peak, ``replay`` runs a schedule in the env, ``objectives`` defines the
objectives, ``mpc`` plans over a moving horizon (``forecasts``: what a controller could know ahead; ``window``: the
plant of one horizon, from forecasts), ``surrogate`` plans heat pumps through the LSTM by sampling (``snapshot``:
copies of the env's state for rollouts), ``optimum`` is the oracle (and MPC) as one call, :func:`optimal`, and
``commands`` registers ``districtgen optimal``.
"""

from pipeline.optimal.optimum import Result, optimal, write_schedule

# the other entry points keep their module's path (pipeline.optimal.oracle.oracle, .replay.replay, .mpc.mpc):
# re-exporting a function under its module's name would hide the module
__all__ = ["Result", "optimal", "write_schedule"]
