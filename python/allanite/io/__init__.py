"""Reading records from files and writing outputs safely."""
