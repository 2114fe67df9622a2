"""Experiments: scenario schema, episode runner, sweeps, results store, reports, CLI."""
