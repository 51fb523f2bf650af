"""Pure decision models (paper Sections II-III): no simulator import anywhere in this package."""
