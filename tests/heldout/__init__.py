"""An independent generator of electrovibration tribometer studies with known truth.

Written from the literature (the seed paper's eqs. 3, 8, 9, 11; Adams et al. 2013 for the
finger pad's friction law; Dzidek et al. 2017 for moisture; load-cell and CAN-logger
realities) and from the study-format contract alone, so that evtribo's analysis can be held
against data it was not tuned to. See ``README.md`` beside this file.
"""
