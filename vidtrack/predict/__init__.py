"""The forward model: from a machine setting to a predicted throw and a recovery device's place.

Chen 2018, section 4 and Fig. 6. The modules, in the order of the chain:

- ``regression``: k1..k4 regressions in natural units (the shipped eqs. 20-23 or a
  ``vidtrack anova --json`` file): loading, validation, term evaluation, and building the
  shipped file from the published tables;
- ``coefficients``: k1..k4 at a setting, their delta-method uncertainty and the
  design-region check (:class:`ExtrapolationWarning`);
- ``trajectory``: the 3-D throw from the release to the ground or an inlet plane, its
  95 % band, and the straw drag parameter;
- ``placement``: the recovery device's H1 and H2 for a given inlet geometry;
- ``forward``: the whole chain for one setting (:func:`predict`, :class:`Prediction`);
- ``plot``: the figure of a prediction (matplotlib only when called).

Every public name is re-exported here: ``from vidtrack.predict import predict``.
"""

from vidtrack.predict.coefficients import (CODED_LIMIT, Coefficient, CoefficientPrediction,
                                           ExtrapolationWarning, predict_coefficients)
from vidtrack.predict.forward import WORKING_DEPTH_M, Prediction, predict
from vidtrack.predict.placement import DevicePlacement, InletGeometry, place_device
from vidtrack.predict.plot import plot_prediction
from vidtrack.predict.regression import (DEFAULT_REGRESSION, FACTOR_NAMES, RESPONSES,
                                         Regression, ResponseModel,
                                         build_published_regression, evaluate_term,
                                         load_regression)
from vidtrack.predict.trajectory import (DEFAULT_CP_S_PER_M, Trajectory, drag_parameter,
                                         throw_trajectory)

__all__ = ["FACTOR_NAMES", "RESPONSES", "DEFAULT_CP_S_PER_M", "ExtrapolationWarning",
           "ResponseModel", "Regression", "load_regression", "build_published_regression",
           "evaluate_term", "Coefficient", "CoefficientPrediction", "predict_coefficients",
           "drag_parameter", "Trajectory", "throw_trajectory", "InletGeometry",
           "DevicePlacement", "place_device", "Prediction", "predict", "plot_prediction",
           "DEFAULT_REGRESSION", "WORKING_DEPTH_M", "CODED_LIMIT"]
