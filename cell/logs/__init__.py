"""Separation logs in the simulation: read as batches, replayed, and diagnosed.

Owns: ``batch`` (logs of one batch of meat), ``replay`` (the tools follow a log's poses, every
channel compared), ``causes`` (the world causes a batch is searched for: a module per cause
and the registry), ``fit`` (a replay's misfit, channel by channel), ``replays`` (the replays of
a batch, side by side), ``search``, ``evidence`` (the engine's evidence for a cause of the
logs), ``diagnosis``, ``report`` and ``command`` (``musclecell replay`` and ``diagnose-logs``). The
episode writes its own log (:mod:`cell.sim.episodelog`); the format is
:mod:`cell.measure.logs`.
May import: the layers below it (:mod:`cell.sim` and those under it, :mod:`cell.measure`,
:mod:`cell.diagnosis`); never :mod:`cell.synthetic`.
"""
