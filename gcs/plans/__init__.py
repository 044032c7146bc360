"""Plan files: the area a team draws (GeoJSON), the planning that turns it into a closed
search and mission files, campaigns of sorties, and the plan folder a flight reads back."""
