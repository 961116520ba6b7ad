"""districtgen pipeline: ingest raw building-stock data and build CityLearn-compatible districts."""
