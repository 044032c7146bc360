"""One flight of the fleet: the controller, the events it publishes, the live return trigger,
operator orders, the online planner, the flight journal and its resumption, the sortie log."""
