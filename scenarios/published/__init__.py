"""Published human findings, reproduced on demand: ``griploop published``'s scoreboard.

- :mod:`.rules`: the three verdict rules (range, direction, band) and the intervals;
- :mod:`.arms`: the conditions a finding runs (the clinical prosthesis, the intact hand);
- :mod:`.findings`: the board's rows, in order, with sources, rules and protocols;
- :mod:`.board`: one sweep of every finding's scenarios, then one row per finding;
- :mod:`.plot`: the board as one figure.

docs/PUBLISHED.md states every row's rule; docs/FORMAT.md the JSON.
"""
