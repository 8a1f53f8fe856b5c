"""Reference solutions. Read them after you have tried."""
