/* The pieces of the XDMF index files (spray.xdmf, impact.xdmf) that ParaView and VisIt read (app/app.h). */
#include <stdio.h>

#include "app/app.h"

void xdmf_inline_indices(FILE *f, const char *indent, size_t n)
{
    fprintf(f, "%s<DataItem Dimensions=\"%zu\" NumberType=\"Int\" Precision=\"8\" Format=\"XML\">", indent, n);
    for (size_t i = 0; i < n; i++)
        fprintf(f, i % 20 == 19 ? "%zu\n" : "%zu ", i);
    fprintf(f, "</DataItem>\n");
}

void xdmf_slab_indices(FILE *f, const char *indent, size_t n, size_t total, const char *dataset)
{
    fprintf(f,
            "%s<DataItem ItemType=\"HyperSlab\" Dimensions=\"%zu\">\n"
            "%s <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 %zu</DataItem>\n"
            "%s <DataItem Dimensions=\"%zu\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">%s</DataItem>\n"
            "%s</DataItem>\n",
            indent, n, indent, n, indent, total, dataset, indent);
}

void xdmf_geometry(FILE *f, const char *indent, size_t n, const char *where)
{
    fprintf(f,
            "%s<Geometry GeometryType=\"XYZ\">\n"
            "%s <DataItem Dimensions=\"%zu 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s/x</DataItem>\n"
            "%s</Geometry>\n",
            indent, indent, n, where, indent);
}

void xdmf_attribute(FILE *f, const char *indent, const char *name, enum xdmf_kind kind, size_t n, const char *where)
{
    char dimensions[64];
    snprintf(dimensions, sizeof dimensions, kind == XDMF_VECTOR ? "%zu 3" : "%zu", n);
    fprintf(f,
            "%s<Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"Node\">\n"
            "%s <DataItem Dimensions=\"%s\" NumberType=\"%s\" Precision=\"8\" Format=\"HDF\">%s/%s</DataItem>\n"
            "%s</Attribute>\n",
            indent, name, kind == XDMF_VECTOR ? "Vector" : "Scalar", indent, dimensions,
            kind == XDMF_INTEGER ? "Int" : "Float", where, name, indent);
}
