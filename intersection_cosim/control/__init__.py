"""Controllers: map a World snapshot to Decisions. See ``registry`` for the list."""
