"""The report's colour maps without matplotlib: its ``viridis`` (the predicted bounds) and ``RdYlGn_r`` (the errors),
as tables of their 256 entries, looked up as matplotlib looks a value up, so that the page's colours are the ones
matplotlib gives, bit for bit, without its import (a sixth of a ``pincal report``).

viridis is by Nathaniel J. Smith, Stefan van der Walt and Eric Firing (CC0); RdYlGn is Cynthia A. Brewer's
ColorBrewer scheme (Apache 2.0) as matplotlib interpolates it. The tables below are written by
``tools/colormap_tables.py`` from matplotlib's own maps (``tests/viz/test_colormaps.py`` compares them).
"""

from __future__ import annotations

import base64
from functools import cache

import numpy as np
import numpy.typing as npt

from pincal.errors import ArgumentError

Array = npt.NDArray[np.float64]


@cache
def _table(name: str) -> Array:
    """The RGB entries (256, 3) of the colour map ``name``, in [0, 1]."""
    try:
        encoded = "".join(_TABLES[name])
    except KeyError:
        raise ArgumentError(f"colour map '{name}' is not one of the report's: {', '.join(_TABLES)}") from None
    table = np.frombuffer(base64.b64decode(encoded), dtype="<f8").astype(np.float64).reshape(-1, 3)
    table.flags.writeable = False
    return table


def colormap(name: str, values: npt.ArrayLike) -> Array:
    """RGBA colours (..., 4) in [0, 1] of ``values`` (any shape, dimensionless, 0 to 1) on the colour map ``name``
    (``"viridis"``, ``"RdYlGn_r"``), as matplotlib's ``colormaps[name](values)`` gives them: a value in the k-th of
    the table's N equal bins takes entry k (1 the last), below 0 the first, above 1 the last; NaN is transparent
    black.

    Raises:
        ArgumentError: ``name`` is not one of the tables here.
    """
    table = _table(name)
    n = len(table)
    scaled = np.array(values, dtype=np.float64) * n
    bad = np.isnan(scaled)
    index = np.clip(np.where(bad, 0.0, scaled), 0.0, n - 1).astype(np.intp)
    rgba = np.ones((*scaled.shape, 4))
    rgba[..., :3] = table[index]
    rgba[bad] = 0.0
    return rgba


# BEGIN TABLES (written by tools/colormap_tables.py)
_TABLES = {
    "viridis": (
        "AK358ZcW0T/Me5xpwvZzPzD186YiFdU/kIgpkUQv0T/PTgZHyauDP02BzM6id9U/VRfwMsNG0T/ByqFFtvONP8KiIk4n2dU/InGP"
        "pQ9d0T+cb0T3rGuUPzOJesGnOdY/JH7FGi5y0T//WfPjLy2aP+qT3GETmdY/AW4WLxaG0T8QH9jxXyCgP0KTxJJy99Y/EhH+RdCY"
        "0T9fmbfqOlSjPysWvymsVNc/LH++LViq0T8W9x+ZDp2mP9EEiljEsNc/INCZtKm60T+IghlTsMapPwh3Z+22C9g/HOxNDMnJ0T/6"
        "tfXTf9asP+vjoe9uZdg/INPaNLbX0T9vRzgteNGvP3tLOV/svdg/0LTEymjk0T8P0H05s12xP4vFbworFdk/W3nJ/+Tv0T87bvjd"
        "dMuyP5GZC1wea9k/wCDp0yr60T+862zIPzO0P2HfTiLCv9k/0sJlFTYD0j+EEmba/pW1P82ueysSE9o/v0f99QoL0j+uKZDZWfS2"
        "P0xPWOIBZdo/WMfxQ6UR0j9XeJeL+E64P7LYJhWNtdo/zCkBMQkX0j/jpDDvcaa5P6J6a2CrBNs/7IZtizIb0j8rMjogCfu6Px41"
        "JsRcUts/FK+ytike0j8nhXmPM028P5xPHauUnts/6dFUT+Yf0j+wIM1YNJ29P+/hkuNO6ds/mdcRh2wg0j/m5hvRPeu+P+oDyTuH"
        "Mtw/I8DpXbwf0j9RLSKKyRvAP2DNAYI5etw/tHOaBdod0j+p3hrYKsHAP/RtwVJdwNw/TvIjfsUa0j8vqG+Z02XBP6jlB67yBN0/"
        "7zuGx34W0j/0+pP43AnCP01MF2L1R90/xTh/EwoR0j+eBgySPq3CP7a5MT1hid0/LLmKxW8K0j8+PEuQEVDDP7dFmQ0yyd0/yOws"
        "eqcC0j8vbM1WXvLDPyAIkKFjB94/Ioyfxr350T9wlpLlJJTEPyHp0yr6Q94/OZfiqrLv0T9dixagbTXFP4oAp3fxft4/PPazWIrk"
        "0T+aet0iMNbFPzBmS1ZFuN4/WJHRAUnY0T+DNGPRdHbGPz8Cf/j5794/uVD51/LK0T9yiSMPRBbHP4nsgywLJt8/vASnPpC80T+y"
        "2CYVjbXHPz0NGCR9Wt8/u31WmSmt0T+d8uhGWFTIP4hM+RBUjd8/idNJtrqc0T8012mkpfLIPzvCacGLvt8/rb66KlCL0T93hqkt"
        "dZDJP4ZWJ2co7t8/VydnKO540T+vX7Abti3KP+Hs1jIZDuA/DcaIRKFl0T83M/rRcMrKP+Kxn8VSJOA//YLdsG1R0T+2MAvtnGbL"
        "P3Hiqx3FOeA/VkYjn1c80T8qWONsOgLMP75muWx0TuA/RPgXQWMm0T842QbuQJ3MP7JK6ZleYuA/qyFxj6UP0T/hs3VwsDfNP6Ze"
        "twiMdeA/uarsuyL40D/KF7SQgNHNP4auRKD6h+A/bJOKxtrf0D/zBMJOsWrOP6oKDcSymeA/fHxCdt7G0D8AqyNHOgPPP/5+MVuy"
        "quA/Fk7S/DGt0D9N2lTdI5vPP9vbLckBu+A/wsBz7+GS0D8S+S6lLhnQP1kV4SajyuA/26SisfZ30D8VkWEVb2TQP6UTCaaa2eA/"
        "6rKY2Hxc0D+KBb6iW6/QPwOzQpHu5+A/HNMTlnhA0D8Whsjp6/nQP3Pzjeie9eA/y9WPTfIj0D+6EoHqH0TRPzqxh/axAuE/gnNG"
        "lPYG0D91q+ek943RP5vIzAUuD+E/2CjrNxPTzz9IUPwYc9fRP64tPC8VG+E/3IKluoCXzz8FGQEVjiDSP7a8cr1tJuE/acU3FD5b"
        "zz9+HThnRGnSP+FdLuI7MeE/28AdqFMezz88FtukorHSP3TtC+iFO+E/Q+bKoNrgzj+2SrA4nPnSP25rC89LReE/VtY2xeOizj8a"
        "o3VUNUHTP0GchxOYTuE/cGHdeHdkzj9oHyv4bYjTP+1/gLVqV+E//MitSbclzj/Op45VSs/TP83mcRjMX+E/sK2f/rPmzT/wayQJ"
        "whXUP/jEOlW+Z+E/QrCqXn6nzT/8U6pE2VvUP7L2d7ZHb+E/s9DOaRZozT/yXyAIkKHUPyhk521sduE/blD7rZ0ozT//d0SF6ubU"
        "P4j1Rq0wfeE/cy8wKxTpzD8knBa86CvVP/+SVKaYg+E/097gC5OpzD9gzJasinDVP6Uw73GmieE/6C6JsyJqzD+zCMVW0LTVP72q"
        "s1pgj+E/asAg6dMqzD9LOV/svfjVP3XpX5LKlOE/smMjEK/ryz8pXmVtUzzWP/rUsUrpmeE/eLmI78Ssyz8djxmojH/WP0xtqYO8"
        "nuE/FJLM6h1uyz+yhLUxdsLWP8eCwqBMo+E/5L1qZcIvyz+4VnvYCwXXP4EJ3Lqbp+E/nN1aJsPxyj8yBWucTUfXP5D11Oqrq+E/"
        "mMEYkSi0yj9LeEKvP4nXPzojSnuDr+E/MjogCft2yj8DsAER4srXP32SO2wis+E/xhft8UI6yj+KlGbzOAzYP3I3iNaKtuE/+IkD"
        "6Pf9yT/dJXFWRE3YP0T67evAueE/2gHXFTPCyT9ZNJ2dDI7YPwvPS8XGvOE/EK/rF+yGyT/P1yyXjc7YP/WdX5Sgv+E/m5FB7iJM"
        "yT9u+N10yw7ZPwJnKVlOwuE/ixpMw/ARyT81lrA2xk7ZP0ceiCzSxOE/KqkT0ETYyD9SmWIOgo7ZP/OrOUAwx+E/1A0UeCefyD/y"
        "6bEtA87ZPwYQPpRoyeE/iEhNu5hmyD8WiJ6USQ3aP4BKlSh7y+E/oik7/aAuyD/qW+Z0WUzaP41D/S5szeE/axDmdi/3xz9vZYnO"
        "MovaPy/7dac7z+E/Ps3Ji0zAxz/SjEXT2cnaP3xl3qrr0OE/HGDmO/iJxz9Buti0UgjbP3OCNjl80uE/qfi/IypUxz+OBYVBmUbb"
        "PxVSflLt0+E/i8ba39kexz8UP8bctYTbP3rIlA9B1eE/d2ouNxjqxj/TZpyGqMLbP5/leXB31uE/XHNH/8u1xj/MfAc/cQDcP52d"
        "DI6S1+E/O+ElOPWBxj9ZUYNpGD7cP0YIjzaO2OE/b4RFRZxOxj9M/FHUmXvcP8cNv5tu2eE/5usy/Kcbxj8BTu/i/bjcPwq6vaQx"
        "2uE/oBfuXBjpxT9KXp1jQPbcPyYBamrZ2uE/+dfyyvW2xT9VFRqIZTPdP+z6Bbth2+E/4LvNGyeFxT9PWyOCcXDdP4qPT8jO2+E/"
        "r5P6srRTxT84MLlRZK3dP9TWiGAc3OE/sr6ByY0ixT89fJkoQurdP8jQsYNK3OE/i2zn+6nxxD9gP8QGCyfeP2d9yjFZ3OE/mG2n"
        "rRHBxD+eeTnsvmPeP7Hc0mpI3OE/xlBOtKuQxD9V+3Q8ZqDeP3kGDf0T3OE/FhbcD3hgxD8o9PqT+NzeP776eOi72+E/iL1QwHYw"
        "xD+fHAWIghnfP2nFNxQ+2+E/G0esxacAxD+PjNXm/1XfP5JaKJmc2uE/GxL3WPrQwz/2Q2ywcJLfPwvSjEXT2eE/hh4xem6hwz8C"
        "K4cW2c7fP703hgDg2OE/uDzWjAxywz/aIJOMnAXgP5KXNbHA1+E/VpxqLcxCwz8buAN1yiPgP5/leXB31uE/uw1qv7UTwz8wZ7Yr"
        "9EHgP6JFtvP91OE/5pDUQsnkwj9EFmniHWDgP8efqGxY0+E/2SWqtwa2wj8r3V1nQ37gP7Mj1Xd+0eE/7ZxmgXaHwj8SpFLsaJzg"
        "P2fROxVwz+E/yCWOPBBZwj/5akdxjrrgP8y0/SsrzeE/ezGUE+0qwj/fMTz2s9jgP8vZO6OtyuE/YJD0aRX9wT+wBFJi1/bgP01M"
        "F2L1x+E/0xIro5HPwT+Wy0bn/BThPzsYsU8AxeE/ilkvhnKiwT99kjtsIjPhP2lVSzrKweE/ldV0PdF1wT97TQ8KSlHhP9UD5iFT"
        "vuE/u5hmutdJwT9iFASPb2/hP4EjgQabuuE/otKImX0ewT92w7ZFmY3hPyfYf52btuE/EJVGzOzzwD90forjwKvhP7ItA85SsuE/"
        "FlETfT7KwD+fIRyz7MnhPwowLH++reE/1ejVAKWhwD/KxK2CGOjhPy/f+rDeqOE/Bf2FHjF6wD/1Zz9SRAbiP8Zq8/+qo+E/exAC"
        "8iVUwD83/686ciTiP/66050nnuE/S5S9pZwvwD94liAjoELiP3r/HydMmOE/AKyOHOkMwD/RIXAk0GDiP2ggls0ckuE/DjLJyFnY"
        "vz8TueAM/n7iP25Nui2Ri+E/uRtEa0Wbvz9rRDAOLp3iP6J6a2CrhOE/sRpLWBtjvz+t26D2W7viP8DLDBtlfeE/7pOjAFEwvz/v"
        "chHfidniP8hAnl2+deE/js75KY4Dvz8xCoLHt/fiP43xYfaybeE/PtAKDFndvj9crROX4xXjPw3eV+VCZeE/GuCCbFm+vj9wXMZN"
        "DTTjPwYq499nXOE/h6QWSianvj9uF5rrNFLjP6W9wRcmU+E/68N6o1aYvj8+6q9XWHDjP6W8VkJ3SeE/rORjd4GSvj/h1AeSd47j"
        "P9k+5C1XP+E/UI9tGXCWvj9sy4CzlKzjP0FEatrFNOE/0Chd+pekvj+05VyKq8rjP8fYCS/BKeE/SPje36C9vj/OF3svvujjP1MI"
        "5BJHHuE/HqSnyCHivj+OeR1xyAbkP87eGW1VEuE/bXNjesISvz8J/yJozCTkPzpcqz3sBeE/wono19ZPvz8/qIsUykLkP1Gk+zkF"
        "+eA/OC7jpgaavz8EjZlEvWDkPxO3CmKg6+A/qOMxA5Xxvz9uoSsRqH7kP4GU2LW93eA/KjdRS3MrwD9Q/YNIhpzkP21UpwNZz+A/"
        "5ngFoidlwD/XiGAcXLrkP8ECmDJwwOA/cvikEwmmwD++ZyRCI9jkP3ufqkIDseA/hlYnZyjuwD80go3r3/XkP4c2ABsQoeA/1zOE"
        "Y5Y9wT/0+/7NixPlP8zTuaKUkOA/ZJC7CFOUwT8rvTYbKzHlPzSD+MCOf+A/ijxJumbywT+W6ZeIt07lP79EvHX+beA/kpc1scBX"
        "wj9iaeBHNWzlP0AwR4/fW+A/xQCJJlDEwj9hVFInoInlP845eCY0SeA/yqfHtgw4wz98tg4O9qblP1BtcCL6NeA/2XqGcMyywz/L"
        "g/QUOcTlP5vicVEtIuA/4QhSKXY0xD82yCQjZ+HlP8WNW8zPDeA/0uC2tvC8xD+oj8Affv7lP0EN38K68d8/iiDOwwlMxT8f2scK"
        "fhvmP4iCGVOwxt8/nIaowp/hxT+Fs1vLZDjmPwSr6uV3mt8/ntFWJZF9xj/aG3xhMlXmP+NuEK0Vbd8/Ek92M6Mfxz/xKmub4nHm"
        "P5wVURN9Pt8/542TwrzHxz/h1AeSd47mP4tvKHy2Dt8/odtLGqN1yD+SJXMs76rmP4GU2LW93d4/LscrED0pyT8EHa1qScfmP1Kc"
        "o46Oq94/E57Q60/iyT8L0/caguPmP/2GiQYpeN4/4h5LH7qgyj+mR1M9mf/mP4JUih2NQ94/MQisHFpkyz/Ver/RjhvnP+IEptO6"
        "Dd4/OEiI8gUtzD9qhH6mXjfnP5PfopOl1t0/Mc10r5P6zD+UTE7tDFPnP/K0/MBVnt0/sFWCxeHMzT/3ArNCkW7nP/2Es1vLZN0/"
        "SaDBps6jzj/Bj2rY74nnP1p/SwD+Kd0/kGtDxTh/zz/a/pWVJqXnP2R0QBL27dw/DDuMSX8v0D8WaHdIMcDnP+571F+vsNw/PL8o"
        "QX+h0D+Mv+0JEtvnP8mtSbclctw/zok9tI8V0T8NHTuoxPXnP/YJoBhZMtw/aMpOP6iL0T+ZgF8jSRDoP0ioGVJF8ds/VOBkG7gD"
        "0j8x6lp7nyroP+twdJXurts/3CqIga590j+ocW9+w0ToP+BjsOJUa9s/pdk8DoP50j/9Fp0stV7oPyiBzTl4Jts/JjRJLCl30z8w"
        "2uOFdHjoP8HIy5pY4No/2IFzRpT20z8qx2Rx/5HoP6w6qwX2mNo/jNr9KsB31D/V6UDWU6voP+nWa3pQUNo/jJ3wEpz61D8xQni0"
        "ccToP0q1T8djBto/rOKNzCN/1T8Q6EzaVN3oP6LtmLoru9k/kNlZ9E4F1j+Jz51g//XoP0xQw7ewbtk/sMka9RCN1j9vEK0VbQ7p"
        "P0jdzr7yINk/sOJUa2EW1z/Bqnr5nSbpP5aUu8/x0dg/CWzOwTOh1z+AngYMkj7pPwiOy7ipgdg/umWH+Ict2D99A5MbRVbpPyiC"
        "OA8nMNg/PBdGelG72D/Rzf5AuW3pP2u4yD1d3dc/MrCO44dK2T9NFYxK6oTpPy4B+KdUidc/b0ijAifb2T8HzhlR2pvpP3Bcxk0N"
        "NNc/xvfFpSpt2j+9GwsKg7LpP9f5t8t+3dY/3e16aYoA2z+E8j6O5sjpP72pSIWxhdY/KnKIuDmV2z9GXtbEAt/pP1BUNqypLNY/"
        "gJwwYTQr3D8DX9Gt1/TpP5D5gEBn0tU/hJz3/3HC3D+kAFEwYwrqP6qB5nPudtU/3KFhMepa3T8oQ1VMpR/qP57sZkY/GtU/K9zy"
        "kZT03T9kPiDQmTTqP8gKfhtivNQ/RWPt72yP3j+D2m/tREnqP8wLsI9OXdQ//U6TGW8r3z9DO6dZoF3qPzOoNjgR/dM/m/7sR4rI"
        "3z+iYMYUrHHqPyrIz0aum9M/ETl9PV8z4D+4Pqw3aoXqP4SDvYkhOdM/muyfpwGD4D9t4Xmp2JjqP8mSOZZ31dI/vLGgMCjT4D+s"
        "VFBR9avqP8wNhjqscNI/SaDBps4j4T90mC8vwL7qP+fEHtrHCtI//dtlv+504T+uuDgqN9HqP9FY+zvbo9E/wXCuYYbG4T9xqUpb"
        "XOPqP4rJG2DmO9E/UYL+Qo8Y4j++amXCL/XqP8i3dw360tA/ajS5GANr4j99CKpGrwbrP7cLzXUaadA/85L/yd+94j+XjjnP2Bfr"
        "P2crL/mf/M8/ks1V8xwR4z875dGNsCjrP5uNlZhnJc8/MPDce7hk4z9QGJRpNDnrP2cOSS2UTM4/ih74GKy44z/ZJ4BiZEnrP+uP"
        "MAxYcs0/RIgrZ+8M5D/TE5Z4QFnrP5NTO8PUlsw/RzmYTYBh5D9X0LTEymjrPydr1EM0uss/Im3jT1S25D9kXdxGA3jrP31Z2qm5"
        "3Mo/pztPPGcL5T/5ugz/6YbrP7kANEqX/sk/k8g+yLJg5T8Y6UXtfpXrP2aEtwchIMk/iUM2kC625T/uz0VDxqPrP7k3v2GiQcg/"
        "RtCYSdQL5j96bwwBwLHrP0+vlGWIY8c/b57qkJth5j+9x5kmbL/rP2yvBb03hsY/qd2vAny35j/kwKvlzszrP8A9z582qsU/xqUq"
        "bXEN5z/uWkI+6NnrP2ahndMs0MQ/VTIAVHFj5z8LfhtivObrP3khHR7C+MM/+7K0U3O55z85KjdRS/PrPzbn4JnQJMM/XFfMCG8P"
        "6D+mR1M9mf/rP+uM74tLVcI/Hk/LD1xl6D9/vi1YqgvsP62+uipQi8E//b0UHjS76D/FjsahfhfsP7MKmwEuyMA/cOtunuoQ6T+l"
        "oNtLGiPsP+if4GJFDcA/Su8bX3tm6T9j0Amhgy7sP0ZCW86luL4/GAXB49u76T/pKXKIuDnsP5FEL6NYbr0/amgDsAER6j+RfZBl"
        "wUTsP8IyNnSzP7w/EjElkuhl6j9yv0NRoE/sP8B7R40JMbs/tI6qJoi66j+610l9WVrsP/+xEB0CR7o/4Lw48dUO6z+XrmAb8WTs"
        "P9OFWP0Rhrk/UN8yp8ti6z80LEZda2/sP9kG7kCd8rg/qyUd5WC26z/BOLh0zHnsP5P98zRgkLg/wac5eZEJ7D9qvHSTGITsP/yp"
        "8dJNYrg/OpUMAFVc7D9enznrU47sPxuC4zJuarg/5gXYR6eu7D+y1eWUgJjsPwzNdRppqbg/aykg7X8A7T/CL/XzpqLsPx+F61G4"
        "Hrk/nBcnvtpR7T+OrWcIx6zsPyS3Jt2WyLk/2SPUDKmi7T+eB3dn7bbsP65GdqVlpLo/OUIG8uzy7T/FVWXfFcHsP/ILryR5rrs/"
        "vXK9baZC7j9eaK7TSMvsPwD9vn/z4rw/Ns07TtGR7j9oP1JEhtXsP1/svfiiPb4/d2nDYWng7j8ot+171N/sP2ovou2Yur8/aVN1"
        "j2wu7z+1w1+TNersPwltOZfiqsA/9pZyvth77z8lWYejq/TsP1bT9UTXhcE/NSiaB7DI7z+9UwH3PP/sP37IW65+bMI/"
    ),
    "RdYlGn_r": (
        "AAAAAAAAAAAaGhoaGhraP5ybm5ubm8s/9KFRAbFgcD/tdPyDC5PaP40PkhSXGcw/9KFRAbFggD/Bz97t/AvbP3+DiI2Sl8w/7XL6"
        "gQmRiD+UKsFX7oTbP3D3fgaOFc0/9KFRAbFgkD9nhaPB3/3bP2JrdX+Jk80/cAqmQd14lD874IUr0XbcP1Pfa/iEEc4/7XL6gQmR"
        "mD8OO2iVwu/cP0VTYnGAj84/attOwjWpnD/hlUr/s2jdPzbHWOp7Dc8/9KFRAbFgoD+18CxppeHdPyg7T2N3i88/MtZ7Icdsoj+I"
        "Sw/TllreP4zXIm65BNA/cAqmQd14pD9bpvE8iNPeP4URniq3Q9A/rz7QYfOEpj8vAdSmeUzfP35LGee0gtA/7XL6gQmRqD8CXLYQ"
        "a8XfP3eFlKOywdA/LKckoh+dqj9rW0w9Lh/gP3C/D2CwANE/attOwjWprD/UiD3yplvgP2j5ihyuP9E/qA954ku1rj8+ti6nH5jg"
        "P2EzBtmrftE/9KFRAbFgsD+o4x9cmNTgP1ptgZWpvdE/E7xmEbxmsT8RERERERHhP1Kn/FGn/NE/MtZ7Icdssj97PgLGiU3hP0vh"
        "dw6lO9I/UfCQMdJysz/la/N6AorhP0Qb88qietI/cAqmQd14tD9OmeQve8bhPzxVboegudI/jyS7Ueh+tT+4xtXk8wLiPzWP6UOe"
        "+NI/rz7QYfOEtj8i9MaZbD/iPy7JZACcN9M/zljlcf6Ktz+LIbhO5XviPycD4LyZdtM/7XL6gQmRuD/1TqkDXrjiPx89W3mXtdM/"
        "DY0PkhSXuT9ffJq41vTiPxh31jWV9NM/E48RlBaZuz8/B9CYYSrjP2SLs9sDLNQ/+HgAiA+Xvj+W70mk/ljjPwJ68mrjW9Q/brH3"
        "PYTKwD/s18Ovm4fjP6BoMfrCi9Q/YSbvt4BJwj9DwD27OLbjPz9XcImiu9Q/VJvmMX3Iwz+aqLfG1eTjP91FrxiC69Q/RhDeq3lH"
        "xT/xkDHSchPkP3s07qdhG9U/OoXVJXbGxj9IeavdD0LkPxojLTdBS9U/KPrMn3JFyD+eYSXprHDkP7cRbMYge9U/Hm/EGW/EyT/1"
        "SZ/0SZ/kP1YAq1UAq9U/EeS7k2tDyz9MMhkA583kP/Tu6eTf2tU/BFmzDWjCzD+jGpMLhPzkP5PdKHS/CtY/882qh2RBzj/5Ag0X"
        "ISvlPzHMZwOfOtY/6UKiAWHAzz9Q64YivlnlP9C6ppJ+atY/7tvMva6f0D+n0wAuW4jlP26p5SFemtY/Z5bI+ixf0T/+u3o5+Lbl"
        "PwyYJLE9ytY/31DEN6se0j9UpPREleXlP6qGY0Ad+tY/WgvAdCne0j+sjG5QMhTmP0l1os/8Kdc/08W7saed0z8Cdehbz0LmP+dj"
        "4V7cWdc/TIC37iVd1D9ZXWJnbHHmP4ZSIO67idc/xDqzK6Qc1T+wRdxyCaDmPyNBX32budc/P/WuaCLc1T8HLlZ+ps7mP8Ivngx7"
        "6dc/uK+qpaCb1j9eFtCJQ/3mP2Ae3ZtaGdg/Mmqm4h5b1z+0/kmV4CvnP/8MHCs6Sdg/qiSiH50a2D8L58OgfVrnP537WroZedg/"
        "JN+dXBva2D9izz2sGonnPzzqmUn5qNg/nZmZmZmZ2T+5t7e3t7fnP9nY2NjY2Ng/Yb0cfNs62j+LZ0Qh/trnP8Mwnw186tg/JOGf"
        "Xh3c2j9eF9GKRP7nP6yIZUIf/Ng/6gQjQV992z8xx130iiHoP5bgK3fCDdk/riimI6Ee3D8Ed+pd0UToP3848qtlH9k/ckwpBuO/"
        "3D/XJnfHF2joP2mQuOAIMdk/NnCs6CRh3T+q1gMxXovoP1LofhWsQtk/+5Mvy2YC3j99hpCapK7oPzxARUpPVNk/wLeyraij3j9Q"
        "Nh0E69HoPyWYC3/yZdk/hNs1kOpE3z8j5qltMfXoPw/w0bOVd9k/R/+4cizm3z/2lTbXdxjpP/hHmOg4idk/hhGeKrdD4D/JRcNA"
        "vjvpP+KfXh3cmtk/aaPfG1iU4D+c9U+qBF/pP8v3JFJ/rNk/SzUhDfnk4D9vpdwTS4LpP7VP64Yivtk/Lcdi/pk14T9CVWl9kaXp"
        "P56nsbvFz9k/Dlmk7zqG4T8UBfbm18jpP4f/d/Bo4dk/8erl4NvW4T/otIJQHuzpP3FXPiUM89k/1Hwn0nwn4j+6ZA+6ZA/qP1uv"
        "BFqvBNo/tg5pwx144j+OFJwjqzLqP0QHy45SFto/mKCqtL7I4j9gxCiN8VXqPy5fkcP1J9o/ejLspV8Z4z8zdLX2N3nqPxe3V/iY"
        "Odo/XMQtlwBq4z8GJEJgfpzqPwEPHi08S9o/P1ZviKG64z/Z087JxL/qP+pm5GHfXNo/IOiweUIL5D+sg1szC+PqP9O+qpaCbto/"
        "A3ryauNb5D9/M+icUQbrP70WccslgNo/5Qs0XISs5D9S43QGmCnrP6ZuNwDJkdo/9vT09PT05D9OgLLkFknrP9VpAJctxNo/NjU1"
        "NTU15T90CqE3zmTrP0YIzI9TF9s/d3V1dXV15T+alI+KhYDrP7eml4h5ats/t7W1tbW15T/AHn7dPJzrPylFY4Gfvds/9/X19fX1"
        "5T/lqGww9LfrP5rjLnrFENw/NjY2NjY25j8LM1uDq9PrPwqC+nLrY9w/eHZ2dnZ25j8xvUnWYu/rP3wgxmsRt9w/uLa2tra25j9X"
        "RzgpGgvsP+6+kWQ3Ct0/+Pb29vb25j990SZ80SbsP19dXV1dXd0/OTc3Nzc35z+iWxXPiELsP9D7KFaDsN0/eXd3d3d35z/I5QMi"
        "QF7sP0Ka9E6pA94/ube3t7e35z/ub/J093nsP7M4wEfPVt4/+ff39/f35z8U+uDHrpXsPyTXi0D1qd4/OTg4ODg46D85hM8aZrHs"
        "P5R1Vzkb/d4/enh4eHh46D9fDr5tHc3sPwcUIzJBUN8/uri4uLi46D+FmKzA1OjsP3iy7ipno98/+vj4+Pj46D+rIpsTjATtP+lQ"
        "uiON9t8/Ozk5OTk56T/RrIlmQyDtP633Qo7ZJOA/e3l5eXl56T/2Nni5+jvtP+bGqIpsTuA/u7m5ubm56T8cwWYMslftPx6WDof/"
        "d+A//Pn5+fn56T9CS1VfaXPtP1dldIOSoeA/Ozo6Ojo66j9n1UOyII/tP4802n8ly+A/fHp6enp66j+OXzIF2KrtP8gDQHy49OA/"
        "vLq6urq66j+z6SBYj8btPwHTpXhLHuE//fr6+vr66j/Zcw+rRuLtPzqiC3XeR+E/PDs7Ozs76z///f39/f3tP3NxcXFxceE/2yl6"
        "yhpr6z93Yk46JhLuP/u3djX0suE/eRi5Wfqa6z/wxp52TibuP4L+e/l29OE/Fwf46NnK6z9oK++ydjruPwpFgb35NeI/tfU2eLn6"
        "6z/gjz/vnk7uP5GLhoF8d+I/VOR1B5kq7D9Z9I8rx2LuPxrSi0X/uOI/8tK0lnha7D/SWOBn73buP6EYkQmC+uI/kMHzJViK7D9K"
        "vTCkF4vuPylfls0EPOM/L7AytTe67D/DIYHgP5/uP7Glm5GHfeM/zZ5xRBfq7D87htEcaLPuPznsoFUKv+M/a42w0/YZ7T+06iFZ"
        "kMfuP8AyphmNAOQ/CXzvYtZJ7T8sT3KVuNvuP0h5q90PQuQ/p2ou8rV57T+ls8LR4O/uP8+/sKGSg+Q/RlltgZWp7T8dGBMOCQTv"
        "P1cGtmUVxeQ/5EesEHXZ7T+WfGNKMRjvP99MuymYBuU/gjbrn1QJ7j8O4bOGWSzvP2eTwO0aSOU/ISUqLzQ57j+HRQTDgUDvP+/Z"
        "xbGdieU/vxNpvhNp7j8AqlT/qVTvP3Ygy3Ugy+U/XQKoTfOY7j94DqU70mjvP/5m0DmjDOY/+/Dm3NLI7j/xcvV3+nzvP4at1f0l"
        "TuY/md8lbLL47j9p10W0IpHvPwz02sGoj+Y/OM5k+5Eo7z/iO5bwSqXvP5U64IUr0eY/1ryjinFY7z9aoOYsc7nvPx2B5UmuEuc/"
        "dKviGVGI7z/TBDdpm83vP6XH6g0xVOc/E5ohqTC47z9LaYelw+HvPywO8NGzlec/sYhgOBDo7z/Ezdfh6/XvP7RU9ZU21+c/3Hwd"
        "vl7/7z+rHpIFeezvP7RU9ZU21+c/lXZYOhz+7z8CXLYQa8XvPywO8NGzlec/TXCTttn87z9YmdobXZ7vP6TH6g0xVOc/BmrOMpf7"
        "7z+u1v4mT3fvPx2B5UmuEuc/vmMJr1T67z8GFCMyQVDvP5c64IUr0eY/d11EKxL57z9bUUc9MynvPw302sGoj+Y/L1d/p8/37z+y"
        "jmtIJQLvP4Wt1f0lTuY/6FC6I4327z8IzI9TF9vuP/1m0DmjDOY/oEr1n0r17z9fCbReCbTuP3Ygy3Ugy+U/WEQwHAj07z+1Rthp"
        "+4zuP+7ZxbGdieU/ET5rmMXy7z8MhPx07WXuP2aTwO0aSOU/yTemFIPx7z9iwSCA3z7uP95MuymYBuU/gjHhkEDw7z+4/kSL0Rfu"
        "P1YGtmUVxeQ/OiscDf7u7z8PPGmWw/DtP8+/sKGSg+Q/8yRXibvt7z9leY2htcntP0d5q90PQuQ/qx6SBXns7z+8trGsp6LtP78y"
        "phmNAOQ/ZBjNgTbr7z8S9NW3mXvtPzfsoFUKv+M/HBII/vPp7z9oMfrCi1TtP7Clm5GHfeM/1QtDerHo7z+/bh7OfS3tPyhfls0E"
        "POM/jQV+9m7n7z8WrELZbwbtP6AYkQmC+uI/Rv+4cizm7z9t6WbkYd/sPxrSi0X/uOI//vjz7unk7z/CJovvU7jsP5CLhoF8d+I/"
        "t/Iua6fj7z8ZZK/6RZHsPwhFgb35NeI/b+xp52Ti7z9vodMFOGrsP4H+e/l29OE/KOakYyLh7z/G3vcQKkPsP/m3djX0suE/4N/f"
        "39/f7z8cHBwcHBzsP3FxcXFxceE/mNkaXJ3e7z8j4qBfHt3rP7VpHtOHPOE/UdNV2Frd7z8rqCWjIJ7rP/hhyzSeB+E/Cc2QVBjc"
        "7z8ybqrmIl/rPzxaeJa00uA/wsbL0NXa7z85NC8qJSDrP39SJfjKneA/esAGTZPZ7z9A+rNtJ+HqP8NK0lnhaOA/M7pByVDY7z9I"
        "wDixKaLqPwZDf7v3M+A/67N8RQ7X7z9Phr30K2PqP5R2WDoc/t8/pK23wcvV7z9WTEI4LiTqPxtnsv1IlN8/XKfyPYnU7z9eEsd7"
        "MOXpP6JXDMF1Kt8/FaEtukbT7z9l2Eu/MqbpPypIZoSiwN4/zZpoNgTS7z9untACNWfpP7Q4wEfPVt4/hpSjssHQ7z90ZFVGNyjp"
        "PzgpGgv87N0/Po7eLn/P7z97KtqJOenoP78ZdM4og90/94cZqzzO7z+C8F7NO6roP0YKzpFVGd0/r4FUJ/rM7z+JtuMQPmvoP836"
        "J1WCr9w/aHuPo7fL7z+RfGhUQCzoP1TrgRivRdw/IHXKH3XK7z+YQu2XQu3nP9zb29vb29s/2G4FnDLJ7z+fCHLbRK7nP2LMNZ8I"
        "cts/kWhAGPDH7z+mzvYeR2/nP+q8j2I1CNs/SWJ7lK3G7z+ulHtiSTDnP3Gt6SVinto/Aly2EGvF7z+1WgCmS/HmP/idQ+mONNo/"
        "ulXxjCjE7z+8IIXpTbLmP3+Onay7ytk/c08sCebC7z/E5gktUHPmPwZ/92/oYNk/K0lnhaPB7z/LrI5wUjTmP45vUTMV99g/5EKi"
        "AWHA7z/SchO0VPXlPxRgq/ZBjdg/fiPJbhS67z/BiVIb5KzlP/abQeeMMtg/++rbzL2u7z+a8UumAFvlPzQjFAX25tc/drLuKmej"
        "7z9uWUUxHQnlP26q5iJfm9c/83kBiRCY7z9EwT68ObfkP6oxuUDIT9c/b0EU57mM7z8aKThHVmXkP+a4i14xBNc/6wgnRWOB7z/w"
        "kDHSchPkPyJAXnyauNY/Z9A5owx27z/H+Cpdj8HjP17HMJoDbdY/45dMAbZq7z+dYCToq2/jP5pOA7hsIdY/YF9fX19f7z9zyB1z"
        "yB3jP9bV1dXV1dU/3CZyvQhU7z9JMBf+5MviPxJdqPM+itU/WO6EG7JI7z8gmBCJAXriP07kehGoPtU/1LWXeVs97z/2/wkUHiji"
        "P4prTS8R89Q/UH2q1wQy7z/MZwOfOtbhP8byH016p9Q/zUS9Na4m7z+iz/wpV4ThPwJ68mrjW9Q/SQzQk1cb7z95N/a0czLhPz4B"
        "xYhMENQ/xdPi8QAQ7z9Pn+8/kODgP3qIl6a1xNM/QZv1T6oE7z8lB+nKrI7gP7UPasQeedM/vmIIrlP57j/+buJVyTzgP/SWPOKH"
        "LdM/OiobDP3t7j+krbfBy9XfPy0eDwDx4dI/tvEtaqbi7j9QfarXBDLfP2ml4R1altI/MrlAyE/X7j/8TJ3tPY7eP6UstDvDStI/"
        "roBTJvnL7j+pHJADd+rdP+Gzhlks/9E/KkhmhKLA7j9W7IIZsEbdPx07WXeVs9E/pw954ku17j8CvHUv6aLcP1nCK5X+Z9E/I9eL"
        "QPWp7j+ui2hFIv/bP5VJ/rJnHNE/n56enp6e7j9bW1tbW1vbP9HQ0NDQ0NA/hOhMsRV67j9EXXaPqMHaPytxt/1DitA/ajL7w4xV"
        "7j8tX5HD9SfaP4URniq3Q9A/T3yp1gMx7j8WYaz3Qo7ZP75jCa9U+s8/NcZX6XoM7j/+YscrkPTYP3Ok1gg7bc8/GhAG/PHn7T/n"
        "ZOJf3VrYPyflo2Ih4M4/AFq0DmnD7T/QZv2TKsHXP9slcbwHU84/5aNiIeCe7T+5aBjIdyfXP49mPhbuxc0/zO0QNFd67T+majP8"
        "xI3WP0inC3DUOM0/sDe/Rs5V7T+KbE4wEvTVP/fn2Mm6q8w/loFtWUUx7T9zbmlkX1rVP6wopiOhHsw/e8sbbLwM7T9ccISYrMDU"
        "P2Bpc32Hkcs/YRXKfjPo7D9Fcp/M+SbUPxSqQNdtBMs/Rl94karD7D8udLoAR43TP8jqDTFUd8o/LKkmpCGf7D8WdtU0lPPSP3wr"
        "24o66sk/EfPUtph67D8AePBo4VnSPzBsqOQgXck/9zyDyQ9W7D/oeQudLsDRP+SsdT4H0Mg/3IYx3IYx7D/ReybReybRP5ntQpjt"
        "Qsg/wtDf7v0M7D+6fUEFyYzQP0wuEPLTtcc/pxqOAXXo6z9F/7hyLObPPwFv3Uu6KMc/jWQ8FOzD6z8XA+/axrLOP7WvqqWgm8Y/"
        "cq7qJmOf6z/pBiVDYX/NP2rwd/+GDsY/WPiYOdp66z+6Clur+0vMPx4xRVltgcU/PUJHTFFW6z+MDpETlhjLP9JxErNT9MQ/JIz1"
        "Xsgx6z9nEsd7MOXJP4qy3ww6Z8Q/CNajcT8N6z8wFv3jyrHIPzrzrGYg2sM//129HHzb6j9FvTWuJp/HPwWHCYwOkcM/BiRCYH6c"
        "6j+eB3HaQ63GP+dt9XwEjMM/DerGo4Bd6j/4UawGYbvFP8lU4W36hsM/FLBL54Ie6j9RnOcyfsnEP6o7zV7wgcM/HHbQKoXf6T+q"
        "5iJfm9fDP4wiuU/mfMM/IzxVboeg6T8EMV6LuOXCP24JpUDcd8M/KgLasYlh6T9de5m31fPBP1DwkDHScsM/Mshe9Ysi6T+2xdTj"
        "8gHBPzLXfCLIbcM/OY7jOI7j6D8QEBAQEBDAPxS+aBO+aMM/QFRofJCk6D/TtJZ4Wjy+P/akVAS0Y8M/SBrtv5Jl6D+GSQ3RlFi8"
        "P9eLQPWpXsM/T+BxA5Um6D843oMpz3S6P7lyLOafWcM/Vqb2Rpfn5z/scvqBCZG4P5tZGNeVVMM/Xmx7ipmo5z+eB3HaQ622P31A"
        "BMiLT8M/ZzIAzptp5z9gnOcyfsm0P18n8LiBSsM/bPiEEZ4q5z8EMV6LuOWyP0EO3Kl3RcM/c74JVaDr5j+2xdTj8gGxPyL1x5pt"
        "QMM/e4SOmKKs5j/UtJZ4WjyuPwTcs4tjO8M/gkoT3KRt5j843oMpz3SqP+bCn3xZNsM/iRCYH6cu5j+gB3HaQ62mP8ipi21PMcM/"
        "kNYcY6nv5T8EMV6LuOWiP6qQd15FLMM/mJyhpquw5T/QtJZ4WjyeP4x3Y087J8M/n2Im6q1x5T+gB3HaQ62WP21eT0AxIsM/piir"
        "LbAy5T/gtJZ4WjyOP09FOzEnHcM/ru4vcbLz5D/AtJZ4Wjx+PzEsJyIdGMM/tbS0tLS05D8AAAAAAAAAABMTExMTE8M/"
    ),
}
# END TABLES
