//! Render passes: shadow map, irradiance gathering, final shading, tone mapping, capture.
