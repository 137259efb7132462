"""Recording runs to MCAP, reading them back, replaying them."""
