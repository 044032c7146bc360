"""What the terminal and the pictures show: the fleet table and the plan overview picture."""
