"""The paper's two-finger pinch (its Tables 3 and 4) in simulation: objects, contacts,
the finger pair, the two controllers through the C step, trials, tables and plots."""
