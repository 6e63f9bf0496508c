"""The ground floor: physical constants and the one parameter system every other floor declares with."""
