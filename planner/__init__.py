"""Pure computation for the DTSCS closed search: maps, motion, rewards, optimisers, return
planners and the scheme joining them. No I/O, no printing."""
