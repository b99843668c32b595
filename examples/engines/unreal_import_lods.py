"""unreal_import_lods.py - import a sylva bake into Unreal Engine 5 as one
static mesh whose LODs are the bake's levels, switched at the bake's screen
sizes (docs/outputs.md, "LOD groups in engines").

Run it in the Unreal Editor (Python Editor Script Plugin enabled), from the
Output Log's Cmd box:

    py "/path/to/unreal_import_lods.py" "/path/to/bake" "/Game/Trees"

It reads the bake's report.json, imports lod0_<name>.fbx as the static mesh
`<asset>` (the report's node names without _LOD<i>) into the content folder,
then each lod<i>_<name>.fbx as its LOD i (StaticMeshEditorSubsystem.import_lod),
and sets the LOD screen sizes: LOD 0 at 1.0, LOD i at the report's
screen_coverage of level i - 1, the fraction of the screen height the tree
covers when the bake switches from level i - 1 to level i. Unreal's screen
size compares the mesh's bounding sphere on screen to the screen's size, so
the switches land near, not exactly at, the bake's (which measures the
tree's height). The FBX files are in centimetres, Unreal's unit; their
textures are beside them (tex_*.png|jpg, atlas_*.png) and are imported with
the materials.
"""
import json
import os
import sys

import unreal


def import_lods(bake_dir, dest):
    with open(os.path.join(bake_dir, "report.json")) as f:
        lods = json.load(f)["lods"]
    fbx = [os.path.join(bake_dir, l["file"][: -len(".glb")] + ".fbx") for l in lods]
    for path in fbx:
        if not os.path.isfile(path):
            raise RuntimeError("missing %s (a bake older than the FBX outputs?)" % path)
    asset = lods[0]["node"].rsplit("_LOD", 1)[0]

    ui = unreal.FbxImportUI()
    ui.set_editor_property("import_mesh", True)
    ui.set_editor_property("import_as_skeletal", False)
    ui.set_editor_property("import_materials", True)
    ui.set_editor_property("import_textures", True)
    ui.set_editor_property("mesh_type_to_import", unreal.FBXImportType.FBXIT_STATIC_MESH)
    ui.static_mesh_import_data.set_editor_property("combine_meshes", True)
    task = unreal.AssetImportTask()
    task.set_editor_property("filename", fbx[0])
    task.set_editor_property("destination_path", dest)
    task.set_editor_property("destination_name", asset)
    task.set_editor_property("automated", True)
    task.set_editor_property("replace_existing", True)
    task.set_editor_property("save", True)
    task.set_editor_property("options", ui)
    unreal.AssetToolsHelpers.get_asset_tools().import_asset_tasks([task])

    mesh = unreal.EditorAssetLibrary.load_asset("%s/%s" % (dest, asset))
    if not isinstance(mesh, unreal.StaticMesh):
        raise RuntimeError("%s did not import as a static mesh" % fbx[0])
    meshes = unreal.get_editor_subsystem(unreal.StaticMeshEditorSubsystem)
    for i in range(1, len(lods)):
        if meshes.import_lod(mesh, i, fbx[i]) != i:
            raise RuntimeError("LOD %d: cannot import %s" % (i, fbx[i]))
    # strictly decreasing and above zero, as Unreal wants them
    sizes = [1.0]
    for l in lods[:-1]:
        sizes.append(min(sizes[-1] * 0.999, max(l["screen_coverage"], 1e-4)))
    if not meshes.set_lod_screen_sizes(mesh, sizes):
        raise RuntimeError("cannot set the LOD screen sizes %s" % sizes)
    unreal.EditorAssetLibrary.save_loaded_asset(mesh)
    unreal.log("%s/%s: %d LODs, screen sizes %s" % (dest, asset, len(lods), sizes))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: unreal_import_lods.py BAKE_DIR /Game/Folder")
    import_lods(sys.argv[1], sys.argv[2])
