"""citylearn_env: a fast, CityLearn-compatible gymnasium environment for district energy control."""
