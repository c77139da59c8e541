"""The batch optimum: corner SLAM over a whole log by sparse least squares (``smoother``), and the
optimum beside a filter run with the filter's ratio to it (``optimum``)."""
