"""The intersection net: generation (netconvert) and geometry read with sumolib."""
