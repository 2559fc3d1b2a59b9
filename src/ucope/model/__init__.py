"""Neural network models of ucope (torch): point cloud encoders and heads."""
