"""The district build: :mod:`.driver` (the one driver, :func:`~pipeline.builder.driver.run_build`) sequences the
pure steps of :mod:`.steps` (selection, site signals, EULP tables, sizing, schema), :mod:`.houses` (stock rows
simulated by EnergyPlus) and :mod:`.surrogates` (LSTM per building, through :mod:`.cache`); it writes into a
:mod:`.staging` folder, validates (:mod:`.validate`, :mod:`.report`) and records (:mod:`.manifest`).
:mod:`.flows` runs it as a Prefect flow (threads or Dask); :mod:`.install` puts a retrained surrogate into a
built district."""
