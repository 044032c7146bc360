"""Rerun recordings: of a plan as it is searched, of a flight, of the experiment figures; and
reading them back."""
