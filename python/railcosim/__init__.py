"""railcosim's Python side of the coupled cases: what every case would otherwise repeat.

  case        the hooks between a case folder and the runner (Case), and their loading
  parameters  case.toml tables, shared defaults and ranges, --smoke and --set
  solvers     FreeFEM and YADE command lines
  dem         the YADE participant's set-up and run/record/save tail (CoupledDem; runs inside YADE)
  results     the DEM recorder, result files, time series, plots and the figures every case reports
"""
