"""Material hookup: show the baked light in EEVEE and Cycles renders (and glTF exports) by making each material of
the baked objects emit base colour x baked light, and undo it exactly.

A node group "Radiosity Baked Light" reads the light (the lightmap image on its UV map, shifted by an object's
``radiosity_lightmap_offset`` for linked duplicates; with several atlas pages, the image of the object's
``radiosity_lightmap_page``; or the colour attribute), multiplies the base colour and adds
the material's own emission. Hooking up adds two nodes (the group, an Emission shader) and re-links the material
output's Surface; the original link is remembered in ``material["radiosity_hookup"]``. Unhooking removes exactly
those nodes and restores the link, so the material is as it was.
"""
from __future__ import annotations

import bpy

from .lightmaps import OFFSET_PROPERTY, PAGE_PROPERTY

GROUP_NAME = "Radiosity Baked Light"
NODE_NAME = "Radiosity Baked Light"
EMISSION_NAME = "Radiosity Baked Light Emission"
REMEMBERED = "radiosity_hookup"


def baked_light_group(uv_map: str | None = None, images=(), attribute: str | None = None):
    """The node group for a lightmap (``uv_map`` and its page ``images``) or a colour ``attribute``; rebuilt each
    time."""
    old = bpy.data.node_groups.get(GROUP_NAME)
    if old is not None:
        bpy.data.node_groups.remove(old)
    group = bpy.data.node_groups.new(GROUP_NAME, "ShaderNodeTree")
    for name, kind in (("Base Color", "INPUT"), ("Emission", "INPUT"), ("Color", "OUTPUT")):
        group.interface.new_socket(name, in_out=kind, socket_type="NodeSocketColor")
    nodes, links = group.nodes, group.links
    inputs, outputs = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    light = _lightmap_nodes(nodes, links, uv_map, images) if images else _attribute_node(nodes, attribute)
    multiply = _mix(nodes, "MULTIPLY")
    links.new(light, multiply.inputs[6])
    links.new(inputs.outputs["Base Color"], multiply.inputs[7])
    add = _mix(nodes, "ADD")
    links.new(multiply.outputs[2], add.inputs[6])
    links.new(inputs.outputs["Emission"], add.inputs[7])
    links.new(add.outputs[2], outputs.inputs["Color"])
    return group


def _lightmap_nodes(nodes, links, uv_map: str, images):
    """The lightmap colour: one image, or the sum over pages of image k x (object's page == k)."""
    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = uv_map
    offset = nodes.new("ShaderNodeAttribute")
    offset.attribute_type, offset.attribute_name = "OBJECT", OFFSET_PROPERTY
    shifted = nodes.new("ShaderNodeVectorMath")
    shifted.operation = "ADD"
    links.new(uv.outputs["UV"], shifted.inputs[0])
    links.new(offset.outputs["Vector"], shifted.inputs[1])
    colours = []
    for image in images:
        texture = nodes.new("ShaderNodeTexImage")
        texture.image, texture.extension, texture.interpolation = image, "EXTEND", "Linear"
        links.new(shifted.outputs["Vector"], texture.inputs["Vector"])
        colours.append(texture.outputs["Color"])
    if len(colours) == 1:
        return colours[0]
    page = nodes.new("ShaderNodeAttribute")
    page.attribute_type, page.attribute_name = "OBJECT", PAGE_PROPERTY
    total = _on_page(nodes, links, page.outputs["Fac"], 0, colours[0])
    for number, colour in enumerate(colours[1:], start=1):
        added = _mix(nodes, "ADD")
        links.new(total, added.inputs[6])
        links.new(_on_page(nodes, links, page.outputs["Fac"], number, colour), added.inputs[7])
        total = added.outputs[2]
    return total


def _on_page(nodes, links, page, number: int, colour):
    """colour x (page == number): a page's image shows only on the objects whose UVs refer to it."""
    chosen = nodes.new("ShaderNodeMath")
    chosen.operation = "COMPARE"
    links.new(page, chosen.inputs[0])
    chosen.inputs[1].default_value, chosen.inputs[2].default_value = float(number), 0.5
    masked = _mix(nodes, "MULTIPLY")
    links.new(colour, masked.inputs[6])
    links.new(chosen.outputs[0], masked.inputs[7])
    return masked.outputs[2]


def _attribute_node(nodes, attribute: str):
    node = nodes.new("ShaderNodeVertexColor")
    node.layer_name = attribute
    return node.outputs["Color"]


def _mix(nodes, blend: str):
    """A colour Mix node (inputs 6 and 7 are A and B, output 2 the result for the RGBA data type)."""
    node = nodes.new("ShaderNodeMix")
    node.data_type, node.blend_type = "RGBA", blend
    node.inputs["Factor"].default_value = 1.0
    return node


def hook_up(material, group) -> bool:
    """Make the material emit base colour x baked light; False if it has no node output to hook up (or is
    hooked up already, in which case only the group is swapped)."""
    tree = material.node_tree if material is not None and material.use_nodes else None
    output = _active_output(tree)
    if output is None:
        return False
    if REMEMBERED in material:
        tree.nodes[NODE_NAME].node_tree = group
        return True
    surface = output.inputs["Surface"]
    shader = surface.links[0].from_node if surface.is_linked else None
    material[REMEMBERED] = {"node": shader.name if shader else "",
                            "socket": surface.links[0].from_socket.identifier if shader else ""}
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree, node.name, node.label = group, NODE_NAME, NODE_NAME
    node.location = (output.location[0] - 400, output.location[1] - 300)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.name = emission.label = EMISSION_NAME
    emission.location = (output.location[0] - 200, output.location[1] - 300)
    _feed_base_colour(tree, shader, node)
    tree.links.new(node.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs["Emission"], surface)
    return True


def _feed_base_colour(tree, shader, node) -> None:
    """The group's Base Color and Emission from the surface shader: linked sources are linked, values copied."""
    base = emission = None
    if shader is not None and shader.type == "BSDF_PRINCIPLED":
        base, emission = shader.inputs["Base Color"], shader.inputs["Emission Color"]
        strength = shader.inputs["Emission Strength"].default_value
        node.inputs["Emission"].default_value = [c * strength for c in emission.default_value[:3]] + [1.0]
    elif shader is not None and shader.type == "BSDF_DIFFUSE":
        base = shader.inputs["Color"]
    elif shader is not None and shader.type == "EMISSION":
        strength = shader.inputs["Strength"].default_value
        node.inputs["Emission"].default_value = [c * strength for c in shader.inputs["Color"].default_value[:3]] + [1.0]
        node.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    if base is not None:
        node.inputs["Base Color"].default_value = base.default_value
        if base.is_linked:
            tree.links.new(base.links[0].from_socket, node.inputs["Base Color"])


def unhook(material) -> bool:
    """Remove the hookup and restore the original Surface link; False if the material was not hooked up."""
    if material is None or REMEMBERED not in material:
        return False
    tree = material.node_tree
    remembered = dict(material[REMEMBERED])
    for name in (NODE_NAME, EMISSION_NAME):
        if name in tree.nodes:
            tree.nodes.remove(tree.nodes[name])
    output = _active_output(tree)
    shader = tree.nodes.get(remembered["node"]) if remembered["node"] else None
    if output is not None and shader is not None:
        socket = next(s for s in shader.outputs if s.identifier == remembered["socket"])
        tree.links.new(socket, output.inputs["Surface"])
    del material[REMEMBERED]
    return True


def _active_output(tree):
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    active = [n for n in outputs if n.is_active_output]
    return (active or outputs or [None])[0]


def materials_of(objects) -> list:
    """The distinct materials of the given objects, in order."""
    seen = {}
    for obj in objects:
        for slot in obj.material_slots:
            if slot.material is not None:
                seen.setdefault(slot.material.name, slot.material)
    return list(seen.values())
