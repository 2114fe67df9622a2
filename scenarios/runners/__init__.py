"""What one scenario does: a runner per scenario kind, the closed-loop episode, comparisons.

:mod:`scenarios.runners.dispatch` maps each scenario kind to its runner (a
registry); :mod:`scenarios.runners.subject` builds the scenario's virtual user and
records their calibration session; :mod:`scenarios.runners.calibration` fits an
estimator on it; :mod:`scenarios.runners.reproduction` runs the paper's evaluation on
a virtual population or one scenario; :mod:`scenarios.runners.trial_loop` is the one
control step every trial runs (simulated, practised, benchmarked, replayed, live), with
its recorder, referee (:mod:`scenarios.runners.trial_outcome`) and ending rule;
:mod:`scenarios.runners.person` puts a virtual subject in it and
:mod:`scenarios.runners.trial` runs one trial of a task;
:mod:`scenarios.runners.episode` runs a grasp from sEMG to the hand;
:mod:`scenarios.runners.feedback_tasks` runs the feedback benchmarks
(eggs, slip recovery, force matching);
:mod:`scenarios.runners.compare` drives one grasp with several estimators;
:mod:`scenarios.runners.video` renders an episode.

May import: sim, estimation, controllers, :mod:`scenarios.schema`, :mod:`scenarios.stats`.
"""
