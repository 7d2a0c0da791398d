// Go needs the opening brace on the line of `func`.
package NextLineBrace

var Drone1 Quadcopter

func INIT()
{
	Drone1.Arm()
}
