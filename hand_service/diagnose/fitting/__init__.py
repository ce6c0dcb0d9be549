"""Output-error least squares of the finger model on a recording."""
