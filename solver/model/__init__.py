"""The physics of the model, one module per thing it is made of (docs/architecture.md): the
cosine basis on the quadrature nodes (basis), the plate and the water's per-mode linear part
(plate), the body's shape and motion (body), the layer's law, forcing and energy (layer), where
body and ice touch (contact), and Parameters -> the Model tuple the kernels take (assemble)."""
