"""The finger model diagnose fits: the output-error problem, its simulation cache and the
nominal model's unit check."""
