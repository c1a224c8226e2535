"""The example scenarios, sweeps and script, shipped inside the package as ``cell.scenarios``
(this folder), so that a regular install has them too: ``musclecell scenarios`` lists them and
copies one out (:mod:`cell.sim.examples`)."""
