"""Paper reproductions that run the trackers (applications on top of them, like bench and tuning)."""
