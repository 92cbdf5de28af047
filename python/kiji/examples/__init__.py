"""Design scripts shipped with Kiji; `experiment` is the 2006 paper's experiment (its section 5)."""
