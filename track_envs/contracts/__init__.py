"""The environment <-> agent contracts: the observation, the report (the action) and its optional
sorting channel, with their spaces, builders and validators."""
